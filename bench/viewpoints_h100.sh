#!/usr/bin/env bash
# The GPU runs behind bench/RESULTS.md "Viewpoints that pay" (one H100), resumable across device
# calls of at most 10 minutes.  Every call does what is left, in this order, within BUDGET
# seconds (default 560), and packs what it made into OUT_DIR/pack.tgz (a call brings back at
# most 8 files):
#   1. train   the whole pipeline (train.py --config gpu, RUN=runs/vp; --resume once started)
#   2. eval    POLICIES (default: vags, vags-no-viewpoint = --no-viewpoint, vags-vanet-estimate =
#              --set vags.view_estimate=vanet; vags-move-cost-X = --set vags.move_cost=X), groups 1-10 x 50
#              rounds, seeds SEEDS (default "11 12 13"),
#              each one eval.py --seeds (compiled once), one after the other: two side by side
#              ran out of GPU memory (each process takes 75 % of it; on-demand allocation,
#              XLA_PYTHON_CLIENT_PREALLOCATE=false, failed a 32.8 GiB allocation in stage 1)
#   3. states  bench/viewpoint_states.py on 6-10 objects: STATES (default "default edge": the run's
#              scenes, then the edge variant)
#   4. sweep   the Fig. 6 quantile sweep, ROUNDS (default 20) rounds a group (plot it where
#              matplotlib is: report_files.plot_sweep on the sweep's JSON); SWEEP=0 skips it
#     bench/viewpoints_h100.sh OUT_DIR            (again, until it prints "all done")
# A piece that would not fit in the budget left is not started.  JAX's persistent compilation
# cache (/tmp/jax_cache) lets later evaluations skip most compiling.  A dry run on a CPU:
#   CONFIG=tiny TRAIN_SET="stage1.iterations=2 ..." EVAL_ARGS="--groups 1-2 --rounds 2" OBJECTS=1-3
#   WORLDS=2 STEPS=1 ROUNDS=2 SWEEP_ARGS="--groups 1-2" RUN=/tmp/vp bench/viewpoints_h100.sh /tmp/vp_out
set -uo pipefail
out=${1:?OUT_DIR}
t_end=$(( $(date +%s) + ${BUDGET:-560} ))
left() { echo $(( t_end - $(date +%s) )); }
mkdir -p "$out"
export PYTHONUNBUFFERED=1
export JAX_COMPILATION_CACHE_DIR=${JAX_COMPILATION_CACHE_DIR:-/tmp/jax_cache}
export JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS=0
run=${RUN:-runs/vp}
res=runs/results/viewpoints/default
mkdir -p "$res" runs/results/viewpoints/edge
pack() { cp "$run/timings.jsonl" "$res/timings_h100.jsonl" 2>/dev/null
         for s in . stage2 stage3; do [ -f "$run/$s/metrics.jsonl" ] && cp "$run/$s/metrics.jsonl" "$res/metrics_${s/./stage1}.jsonl"; done
         tar czf "$out/pack.tgz" -C runs results; }
trained() { python - "$run" <<'EOF'
import sys
from vags_jax.stages import checkpoint, rundir as pipeline
run = sys.argv[1]
try:
    cfg = checkpoint.load_config(run)
except Exception:
    sys.exit(1)
sys.exit(0 if all(pipeline.progress(run, n) >= pipeline.total(cfg, n) for n in pipeline.ORDER) else 1)
EOF
}

if [ "${SKIP_TRAIN:-0}" != 1 ] && ! trained; then  # SKIP_TRAIN=1: RUN holds networks brought from elsewhere
  if [ -d "$run/checkpoints" ]; then how=(--resume); else how=(--config "${CONFIG:-gpu}" ${TRAIN_SET:+--set $TRAIN_SET}); fi
  mins=$(python -c "print(max(0.5, ($(left) - 45) / 60))")
  python train.py "${how[@]}" --out "$run" --checkpoint-every 1000 --max-minutes "$mins" --quiet \
    2>&1 | tee -a "$res/train.txt" | grep -v "^ *$" | tail -4 | cut -c1-600
  trained || { echo "training not done yet: call again"; pack; exit 0; }
fi

seeds=${SEEDS:-11 12 13}
missing() { for s in $seeds; do [ -f "$res/seed$s/eval_$1.json" ] || printf '%s,' "$s"; done; }
policies=${POLICIES:-vags vags-no-viewpoint vags-vanet-estimate}
flags() { case $1 in vags-no-viewpoint) echo --no-viewpoint;; vags-vanet-estimate) echo --set vags.view_estimate=vanet;;
                  vags-move-cost-*) echo --set vags.move_cost=${1#vags-move-cost-};; esac; }
if [ -n "$(for p in $policies; do missing $p; done)" ]; then
  for p in $policies; do
    m=$(missing $p); [ -z "$m" ] && continue
    if [ "$(left)" -lt 200 ]; then echo "no time for $p: call again"; pack; exit 0; fi
    read -ra flag <<< "$(flags $p)"
    timeout $(( $(left) - 10 )) python eval.py --run "$run" "${flag[@]}" --seeds "${m%,}" ${EVAL_ARGS:-} \
      --out "$res/seed{seed}/eval_$p.json" > "$res/eval_$p.txt" 2>&1
  done
  for p in $policies; do grep -A5 "seed |" "$res/eval_$p.txt" || tail -2 "$res/eval_$p.txt"; done
fi

for v in ${STATES:-default edge}; do
  f=runs/results/viewpoints/$v/states_6-10.json
  [ -f "$f" ] && continue
  if [ "$(left)" -lt 150 ]; then echo "no time for states ($v): call again"; pack; exit 0; fi
  scen=(); [ "$v" = edge ] && scen=(--scenes edge)
  timeout $(( $(left) - 10 )) python bench/viewpoint_states.py --run "$run" "${scen[@]}" --objects "${OBJECTS:-6-10}" \
    --worlds "${WORLDS:-256}" --steps "${STEPS:-3}" --out "$f" > "${f%.json}.txt" 2>&1
  grep '^|' "${f%.json}.txt" | head -8 || tail -3 "${f%.json}.txt"
done

r=${ROUNDS:-20}
if [ "${SWEEP:-1}" != 0 ] && [ ! -f "$res/eval_vags_r${r}_sweep.json" ]; then
  if [ "$(left)" -lt 200 ]; then echo "no time for the sweep: call again"; pack; exit 0; fi
  timeout $(( $(left) - 10 )) python eval.py --run "$run" --rounds "$r" --seed 11 --quantile-sweep 0:1:0.1 ${SWEEP_ARGS:-} \
    --out "$res/eval_vags_r$r.json" > "$res/sweep.txt" 2>&1
  grep '^|' "$res/sweep.txt" | tail -14
fi
pack
echo "all done"
