#!/usr/bin/env bash
# The GPU runs behind bench/RESULTS.md "Viewpoints that pay" (one H100), in stages that each
# fit one device call (10 minutes).  Everything a stage writes is packed into OUT_DIR/pack.tgz
# (a device call brings back at most 8 files).
#   bench/viewpoints_h100.sh OUT_DIR train    the pipeline (bench/vags_h100.sh train, RUN=runs/vp)
#   bench/viewpoints_h100.sh OUT_DIR eval     VAGS and --no-viewpoint, groups 1-10 x 50 rounds,
#                                             seeds SEEDS (default "11 12 13")
#   bench/viewpoints_h100.sh OUT_DIR states   bench/viewpoint_states.py on 6-10 and 1-5 objects
#   bench/viewpoints_h100.sh OUT_DIR ablate   the paper's planner and gate on the same networks
#   bench/viewpoints_h100.sh OUT_DIR sweep    the Fig. 6 sweep, ROUNDS (default 20) rounds a group
# One H100 needs about 25 minutes for train (GG-CNN ~4.4 min, stage 1 ~4.2, stages 2-3 ~6-8),
# eval (a VAGS table takes over a minute with its compiles) and states; bench/RESULTS.md
# "Viewpoints that pay" tells how a shorter lease ended.
# JAX's persistent compilation cache (JAX_COMPILATION_CACHE_DIR, default /tmp/jax_cache) lets
# the evaluations after the first skip most compiling.
set -euo pipefail
out=${1:?OUT_DIR}; stage=${2:?stage}
mkdir -p "$out"
export PYTHONUNBUFFERED=1
export JAX_COMPILATION_CACHE_DIR=${JAX_COMPILATION_CACHE_DIR:-/tmp/jax_cache}
export JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS=0
run=${RUN:-runs/vp}
scenes=${SCENES:-default}
res=runs/results/viewpoints/$scenes
mkdir -p "$res"
case $stage in
  train)
    RUN=$run bench/vags_h100.sh "$out/train" train || true
    tar czf "$out/pack.tgz" -C "$out" train ;;
  eval)
    for s in ${SEEDS:-11 12 13}; do
      mkdir -p "$res/seed$s"
      for p in vags vags-no-viewpoint; do
        flag=(); [ "$p" = vags-no-viewpoint ] && flag=(--no-viewpoint)
        python eval.py --run "$run" "${flag[@]}" --seed "$s" --out "$res/seed$s/eval_$p.json" ${EVAL_SET:-} \
          > "$res/seed$s/eval_$p.txt" 2>&1 || true
        echo "seed $s $p: $(grep '^| \*\*overall' "$res/seed$s/eval_$p.txt" || tail -1 "$res/seed$s/eval_$p.txt")"
      done
    done
    tar czf "$out/pack.tgz" -C runs results ;;
  states)
    for objs in 6-10 1-5; do
      python bench/viewpoint_states.py --run "$run" --objects "$objs" --worlds "${WORLDS:-512}" --steps "${STEPS:-8}" \
        --out "$res/states_$objs.json" > "$res/states_$objs.txt" 2>&1 || true
      grep '^|' "$res/states_$objs.txt" || tail -3 "$res/states_$objs.txt"
    done
    tar czf "$out/pack.tgz" -C runs results ;;
  ablate)
    s=${SEED:-11}; mkdir -p "$res/seed$s"
    for v in "ggcnn-planner:vags.local_planner=ggcnn" "q-gate:vags.gate=q" "paper:vags.local_planner=ggcnn vags.gate=q"; do
      name=${v%%:*}; sets=${v#*:}
      python eval.py --run "$run" --seed "$s" --out "$res/seed$s/eval_vags-$name.json" --set $sets \
        > "$res/seed$s/eval_vags-$name.txt" 2>&1 || true
      echo "seed $s $name: $(grep '^| \*\*overall' "$res/seed$s/eval_vags-$name.txt" || tail -1 "$res/seed$s/eval_vags-$name.txt")"
    done
    tar czf "$out/pack.tgz" -C runs results ;;
  sweep)
    python eval.py --run "$run" --rounds "${ROUNDS:-20}" --seed "${SEED:-11}" --quantile-sweep 0:1:0.1 --out "$res/eval_vags_r${ROUNDS:-20}.json" --plot "$res/fig7_r${ROUNDS:-20}.png" \
      > "$res/sweep.txt" 2>&1 || true
    grep '^|' "$res/sweep.txt" | tail -25
    tar czf "$out/pack.tgz" -C runs results ;;
  *) echo "unknown stage $stage"; exit 2 ;;
esac
