#!/usr/bin/env bash
# The GPU runs behind bench/RESULTS.md "Close views and GG-CNN" (one H100), in stages that each
# fit one device call:  bench/ggcnn_h100.sh OUT_DIR speed|data|train|eval
set -euo pipefail
out=${1:?OUT_DIR}; stage=${2:?stage}
mkdir -p "$out"
export PYTHONUNBUFFERED=1
run=runs/ggcnn
quiet() { grep -v "^Module\|Warning\|cuda_timer" || true; }
case $stage in
  speed)  # GG-CNN updates/s: transposed convs phase by phase vs on the dilated input
    python bench/ggcnn_speed.py --batch 32 --size 300 --steps 30 --out "$out/ggcnn_speed.json" | tail -3 ;;
  data)  # make the physics-labelled views (cached in data/ggcnn; one update only)
    python train.py --config gpu --stage ggcnn --out runs/ggcnn_data --data-dir data/ggcnn \
      --set ggcnn.train_steps=1 > "$out/ggcnn_data.txt" 2>&1; quiet < "$out/ggcnn_data.txt" | tail -8 ;;
  train)  # train GG-CNN on the cached views, held-out accuracy in physics (STEPS: updates)
    rm -rf "$run"
    python train.py --config gpu --stage ggcnn --out "$run" --data-dir data/ggcnn \
      --set ggcnn.train_steps=${STEPS:-6000} > "$out/ggcnn_train.txt" 2>&1; quiet < "$out/ggcnn_train.txt" | tail -6
    cp "$run"/ggcnn/metrics.json "$out/ggcnn_metrics.json" ;;
  eval)  # the benchmark, groups 1-10 x 50 rounds: GG-CNN from the global view, from a close view, the heuristic
    for policy in ggcnn-close ggcnn; do
      python eval.py --run "$run" --policy "$policy" --out "$out/eval_$policy.json" > "$out/eval_$policy.txt" 2>&1
      grep "^|" "$out/eval_$policy.txt" | tail -2
    done
    python eval.py --config gpu --policy heuristic --out "$out/eval_heuristic.json" > "$out/eval_heuristic.txt" 2>&1
    grep "^|" "$out/eval_heuristic.txt" | tail -1 ;;
  *) echo "unknown stage $stage"; exit 2 ;;
esac
