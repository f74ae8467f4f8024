#!/usr/bin/env bash
# Table 1 and Fig. 7 of the paper on one H100: VAGS, GG-CNN, MVP, NBV and VPG on the same
# scenes, groups 1-10 x 50 rounds, on the default objects and on --objects unseen.  Resumable: every call does what is left, in this order, within BUDGET
# seconds (default 560, for device calls of at most 10 minutes), and says "all done" at the end:
#   1. train  RUN (default runs/table1; give an existing VAGS run to reuse it): the whole
#             pipeline with GG-CNN (train.py --config gpu --set vags.train_ggcnn=true), resumed
#             until every stage is done; a finished run without GG-CNN gets one
#             (train.py --stage ggcnn)
#   2. nbv    the NBV baseline's network (train.py --stage nbv), resumed until done
#      vpg    VPG's push and grasp nets (train.py --config CONFIG --stage vpg into RUN/vpg), for
#             VPG_MINUTES (default 5) of training clock, when METHODS has vpg
#             (SKIP_TRAIN=1 skips 1 and 2: RUN holds networks brought from another machine)
#   3. eval   METHODS (default "vags ggcnn mvp nbv vpg") on OBJECT_SETS (default "default unseen"),
#             one eval.py per method (compiled once each), reports
#             in OUT/<objects>/eval_<method>.json; a method that fails is logged and skipped
#   4. table  eval.py --compare of those reports: Table 1 (OUT/<objects>/table1.md, .json, .csv)
#             and Fig. 7 (OUT/<objects>/fig7.png); the compare refuses reports of other scenes
# Wall clocks: RUN/timings.jsonl (training, copied to OUT) and OUT/timings.txt (every command).
#     RUN=runs/vags bench/table1_h100.sh OUT       (again, until it prints "all done")
# In device calls keep RUN and OUT under runs/ (kept on the machine while it stays warm) and copy
# OUT back each time:  RUN=runs/table1 bench/table1_h100.sh runs/table1_out; cp -r runs/table1_out "$OUT"/
# A CPU dry run: CONFIG=tiny TRAIN_SET="stage1.iterations=2 stage2.iterations=2 stage3.iterations=2
#   nbv.iterations=2 ggcnn.train_steps=2" EVAL_ARGS="--groups 1-2 --rounds 2" RUN=/tmp/t1 bench/table1_h100.sh /tmp/t1_out
set -uo pipefail
out=${1:?OUT_DIR}
t_end=$(( $(date +%s) + ${BUDGET:-560} ))
left() { echo $(( t_end - $(date +%s) )); }
mkdir -p "$out"
export PYTHONUNBUFFERED=1
export JAX_COMPILATION_CACHE_DIR=${JAX_COMPILATION_CACHE_DIR:-/tmp/jax_cache}
export JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS=0
run=${RUN:-runs/table1}
data=${DATA_DIR:-data/ggcnn}
timed() { local t0; t0=$(date +%s); "$@"; local rc=$?; echo "$(date +%FT%T) $(( $(date +%s) - t0 )) s rc=$rc: $*" >> "$out/timings.txt"; return $rc; }
mins() { python -c "print(max(0.5, ($(left) - ${1:-45}) / 60))"; }
progress() { python - "$run" "$1" <<'EOF'
import sys
from vags_jax.stages import checkpoint, rundir
run, what = sys.argv[1], sys.argv[2]
try:
    cfg = checkpoint.load_config(run)
except Exception:
    sys.exit(1)
names = rundir.ORDER if what == "pipeline" else (what,)
sys.exit(0 if all(rundir.progress(run, n) >= max(1, rundir.total(cfg, n)) or (n == "ggcnn" and what == "pipeline"
                  and rundir.total(cfg, n) == 0) for n in names) else 1)
EOF
}
stop() { cp "$run/timings.jsonl" "$out/train_timings.jsonl" 2>/dev/null; echo "$1: call again"; exit 0; }

methods=${METHODS-vags ggcnn mvp nbv vpg}
# 1. the VAGS run, with a GG-CNN
if [ "${SKIP_TRAIN:-0}" != 1 ] && ! progress pipeline; then
  if [ -f "$run/config.json" ]; then how=(--resume); else
    how=(--config "${CONFIG:-gpu}" --set vags.train_ggcnn=true ${TRAIN_SET:-}); fi
  timed python train.py "${how[@]}" --out "$run" --data-dir "$data" --checkpoint-every 1000 --max-minutes "$(mins)" \
    --quiet >> "$out/train.txt" 2>&1
  tail -2 "$out/train.txt" | cut -c1-600
  progress pipeline || stop "training not done yet"
fi
if [ "${SKIP_TRAIN:-0}" != 1 ] && ! progress ggcnn; then
  [ "$(left)" -lt 300 ] && stop "no time for GG-CNN"
  timed python train.py --config "${CONFIG:-gpu}" --stage ggcnn --out "$run" --data-dir "$data" --quiet \
    ${TRAIN_SET:+--set $TRAIN_SET} >> "$out/train.txt" 2>&1
  tail -1 "$out/train.txt" | cut -c1-600
  progress ggcnn || stop "GG-CNN not trained (see $out/train.txt)"
fi

# 2. NBV
if [ "${SKIP_TRAIN:-0}" != 1 ] && ! progress nbv; then
  timed python train.py --out "$run" --stage nbv --checkpoint-every 1000 --max-minutes "$(mins)" --quiet \
    >> "$out/train.txt" 2>&1
  tail -1 "$out/train.txt" | cut -c1-600
  progress nbv || stop "NBV not done yet"
fi
# VPG, on a budget of training clock (its own config in RUN/vpg)
if [[ " $methods " == *" vpg "* ]] && [ ! -f "$out/vpg_trained" ]; then
  how=(--config "${CONFIG:-gpu}"); [ -d "$run/vpg/checkpoints" ] && how=(--resume)
  [ "$(left)" -lt 200 ] && stop "no time for VPG"
  timed python train.py "${how[@]}" --stage vpg --out "$run" --checkpoint-every 1000 \
    --max-minutes "$(python -c "print(min(${VPG_MINUTES:-5}, max(0.5, ($(left) - 60) / 60)))")" --quiet \
    ${VPG_SET:+--set $VPG_SET} >> "$out/train.txt" 2>&1
  tail -1 "$out/train.txt" | cut -c1-600
  [ -d "$run/vpg/checkpoints" ] && touch "$out/vpg_trained" || stop "VPG not trained (see $out/train.txt)"
  cp "$run/vpg/timings.jsonl" "$out/vpg_timings.jsonl" 2>/dev/null
fi
cp "$run/timings.jsonl" "$out/train_timings.jsonl" 2>/dev/null

# 3. every method on every object set
for objects in ${OBJECT_SETS:-default unseen}; do
  mkdir -p "$out/$objects"
  obj=(); [ "$objects" = unseen ] && obj=(--objects unseen)
  for m in $methods; do
    f="$out/$objects/eval_$m.json"
    [ -f "$f" ] || [ -f "$out/$objects/failed_$m.txt" ] && continue
    [ "$(left)" -lt 150 ] && stop "no time for $m ($objects)"
    txt="$out/$objects/eval_$m.txt"
    t0=$(date +%s)
    timeout $(( $(left) - 10 )) python eval.py --run "$run" --policy "$m" "${obj[@]}" \
      ${EVAL_ARGS:---groups 1-10 --rounds 50} --out "$f" > "$txt" 2>&1
    rc=$?
    echo "$(date +%FT%T) $(( $(date +%s) - t0 )) s rc=$rc: eval.py --policy $m ($objects)" >> "$out/timings.txt"
    if [ -f "$f" ]; then
      echo "$m ($objects): $(grep -m1 '^| \*\*overall' "$txt")"
    else
      tail -3 "$txt" | cut -c1-600
      [ $rc -eq 124 ] && stop "$m ($objects) ran out of time"
      cp "$txt" "$out/$objects/failed_$m.txt"; echo "$m ($objects) failed: left out of the table"
    fi
  done
done

# 4. Table 1 and Fig. 7 from the saved reports (the same scenes, or the compare refuses them)
for objects in ${OBJECT_SETS:-default unseen}; do
  reps=$(ls "$out/$objects"/eval_*.json 2>/dev/null)
  [ -z "$reps" ] && continue
  plot=(--plot "$out/$objects/fig7.png")
  python -c "import matplotlib" 2>/dev/null || plot=()
  python eval.py --compare $reps --out "$out/$objects/table1.json" "${plot[@]}" > "$out/$objects/table1.md" 2> "$out/$objects/table1.err" \
    || { cat "$out/$objects/table1.err"; stop "the $objects table failed"; }
  echo "## $objects objects"; cat "$out/$objects/table1.md"
done
echo "all done"
