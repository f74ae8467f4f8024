#!/usr/bin/env bash
# The GPU runs behind bench/RESULTS.md "VAGS end to end" (one H100), in stages that each fit one
# device call (10 minutes; a machine is held at most 30 minutes):
#   bench/vags_h100.sh OUT_DIR data     GG-CNN's physics-labelled views (cached in data/ggcnn)
#   bench/vags_h100.sh OUT_DIR train    the whole pipeline, MIN minutes per call (default 8);
#                                       call again to resume it; copies timings and metrics to OUT
#   bench/vags_h100.sh OUT_DIR eval     groups 1-10 x 50 rounds: vags, vags --no-viewpoint, ggcnn, heuristic
#   bench/vags_h100.sh OUT_DIR sweep    the threshold sweeps (ROUNDS rounds per group, default 20)
# RUN (default runs/vags) is the run directory.
set -euo pipefail
out=${1:?OUT_DIR}; stage=${2:?stage}
mkdir -p "$out"
export PYTHONUNBUFFERED=1
run=${RUN:-runs/vags}
case $stage in
  data)
    python train.py --config gpu --stage ggcnn --out runs/ggcnn_data --data-dir data/ggcnn \
      --set ggcnn.train_steps=1 > "$out/ggcnn_data.txt" 2>&1; tail -4 "$out/ggcnn_data.txt" ;;
  train)
    # TRAIN_SET: --set overrides for a fresh run (e.g. a smaller GG-CNN when device time is short).
    if [ -f "$run/config.json" ]; then resume=(--resume); else resume=(--config gpu ${TRAIN_SET:+--set $TRAIN_SET}); fi
    python train.py "${resume[@]}" --out "$run" --data-dir data/ggcnn --checkpoint-every 1000 \
      --max-minutes "${MIN:-8}" --quiet > "$out/train_$(date +%H%M%S).txt" 2>&1 || true
    tail -3 "$out"/train_*.txt | cut -c1-1500
    cp "$run/timings.jsonl" "$out/" || true
    for s in . stage2 stage3; do [ -f "$run/$s/metrics.jsonl" ] && cp "$run/$s/metrics.jsonl" "$out/metrics_${s/./stage1}.jsonl"; done
    cp "$run/ggcnn/metrics.json" "$out/ggcnn_metrics.json" 2>/dev/null || true
    # The networks alone (a few MB), for evaluation on another machine.
    tar czf "$out/vags_networks.tgz" --exclude='*/stage2/checkpoints' --exclude='*/stage3/checkpoints' \
      --exclude="$run/checkpoints" "$run/config.json" "$run/ggcnn" $(ls -d "$run"/stage2/networks "$run"/stage3/networks 2>/dev/null) || true ;;
  eval)
    for p in vags vags-no-viewpoint ggcnn; do
      flag=(--policy "${p%%-no-viewpoint}"); [ "$p" = vags-no-viewpoint ] && flag+=(--no-viewpoint)
      python eval.py --run "$run" "${flag[@]}" --out "$out/eval_$p.json" > "$out/eval_$p.txt" 2>&1 || true
      grep "^|" "$out/eval_$p.txt" | tail -1
    done
    python eval.py --config gpu --policy heuristic --out "$out/eval_heuristic.json" > "$out/eval_heuristic.txt" 2>&1 || true
    grep "^|" "$out/eval_heuristic.txt" | tail -1 ;;
  sweep)
    python eval.py --run "$run" --rounds "${ROUNDS:-20}" --threshold-sweep 1.70:1.80:0.01 --quantile-sweep 0:1:0.2 \
      --out "$out/eval_vags_r${ROUNDS:-20}.json" > "$out/sweep.txt" 2>&1 || true
    grep "^|" "$out/sweep.txt" | tail -10 ;;
  *) echo "unknown stage $stage"; exit 2 ;;
esac
