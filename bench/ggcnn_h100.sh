#!/usr/bin/env bash
# The GPU runs behind bench/RESULTS.md "Close views and GG-CNN" (one H100), in stages that each
# fit one device call:  bench/ggcnn_h100.sh OUT_DIR train|eval
set -euo pipefail
out=${1:?OUT_DIR}; stage=${2:?stage}
mkdir -p "$out"
export PYTHONUNBUFFERED=1
run=runs/ggcnn
case $stage in
  train)  # make (or reuse) the physics-labelled dataset, train GG-CNN, held-out accuracy in physics
    python train.py --config gpu --stage ggcnn --out "$run" --data-dir data/ggcnn 2>&1 | grep -v Warning | tee "$out/ggcnn_train.txt"
    cp "$run"/ggcnn/*.json "$out/" 2>/dev/null || true ;;
  eval)  # the benchmark, groups 1-10 x 50 rounds: GG-CNN from the global view, from a close view, the heuristic
    for policy in ggcnn ggcnn-close heuristic; do
      python eval.py --run "$run" --policy "$policy" --out "$out/eval_$policy.json" 2>&1 | grep -v Warning | tee "$out/eval_$policy.txt"
    done ;;
  *) echo "unknown stage $stage"; exit 2 ;;
esac
