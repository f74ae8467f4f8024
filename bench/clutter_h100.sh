#!/usr/bin/env bash
# The GPU runs behind bench/RESULTS.md "Cluttered scenes" (one H100), in stages so that each fits
# one device call:  bench/clutter_h100.sh OUT_DIR parity|throughput|train|difficulty
set -euo pipefail
set -f  # no globbing: the overrides hold JSON lists
out=${1:?OUT_DIR}; stage=${2:?stage}
mkdir -p "$out"
export PYTHONUNBUFFERED=1
LEGACY='scene.shapes=["cuboid_long","cuboid_flat","cube","cuboid_tall","cube_half","arch","disc","cylinder","prism","half_cylinder"];scene.placement=scatter;scene.colour_jitter=0;camera.noise.enabled=false;camera.global_position=[0,-0.25,0.6]'
case $stage in
  parity)  # Warp renderer vs the JAX ray caster on the new scenes (per-world object sizes)
    python bench/render_parity.py --worlds 64 --objects 10 --out "$out/render_parity.json" 2>&1 | tee "$out/render_parity.txt" ;;
  parity3)  # the same, split by object family: boxes only, and the first benchmark's blocks
    python bench/render_parity.py --worlds 64 --objects 10 --out "$out/render_parity.json" 2>&1 | grep -v "^Module" | tee "$out/render_parity.txt"
    python bench/render_parity.py --worlds 64 --objects 10 --set 'scene.shapes=["box","box","box","box","box","box","box","box","box","box"]' \
      --out "$out/render_parity_boxes.json" 2>&1 | grep -v "^Module" | tee "$out/render_parity_boxes.txt"
    python bench/render_parity.py --worlds 64 --objects 10 --set ${LEGACY//;/ } 2>&1 | grep -v "^Module" | tee "$out/render_parity_legacy.txt" ;;
  throughput)  # training-loop attempts/s: the first benchmark's scenes vs the new ones, side by side
    python bench/env_throughput.py --config gpu --impl warp --renderer warp --objects 10 --repeats 1 --loop 6 \
      --only-loop --set camera.render_batch=1024 --worlds 4096 \
      --variant "old_scenes:$LEGACY" --variant "new_scenes:" --variant "new_scenes_no_sensor_model:camera.noise.enabled=false" \
      --out "$out/loop_clutter_4096.json" 2>&1 | grep -v Warning | tee "$out/throughput.txt" ;;
  train)  # stage 1 (GDNet) on the new scenes, 3.5 minutes
    python train.py --config gpu --out runs/clutter --chunk 4 --checkpoint-every 1000 --max-minutes 3.5 --quiet 2>&1 | tail -20 | tee "$out/train.txt"
    cp runs/clutter/config.json "$out/stage1_clutter_config.json"; cp runs/clutter/metrics.jsonl "$out/stage1_clutter_metrics.jsonl" ;;
  difficulty)  # random, heuristic and the trained GDNet, groups 1-10 x 50 rounds, training and unseen objects
    python bench/difficulty.py --run runs/clutter --policies random,heuristic,gdnet --objects train,unseen \
      --groups 1-10 --rounds 50 --out-dir "$out" 2>&1 | grep -v Warning | tee "$out/difficulty.txt" ;;
  *) echo "unknown stage $stage"; exit 2 ;;
esac
