#!/usr/bin/env bash
# Issue 27, on ONE bare H100 (about 25 minutes with a cold cache): the two looks prepared on
# 2026-11-29 for one H200 (pipeline_warp_renderer/driver_finish.sh and actor_clip/driver.sh),
# cut to fit one 30-minute device budget, in this order:
# 1. Pair 34's Warp side trained again alone, the same command as driver_1gpu.sh's w34
#    (train.py --config gpu --set seed=34 camera.renderer=warp camera.render_batch=512), then
#    benchmarked as VAGS and its ablation (groups 1-10 x 50 rounds, seeds 11-13, both at once).
#    Its files go to pipeline_warp_renderer/finish/w34b; driver_1gpu.sh's rule is applied
#    unchanged by that directory's tables.py.  The H200 run of 2026-11-29 ran out of memory under a
#    0.45 cap; if this one runs out of memory under JAX's default 0.75 of the H100, it is trained
#    once more at 0.95 (w34c), and a Warp preset that needs that is not a default for an H100.
#    trunk_speed.py and the stage-3 phases of driver_finish.sh are left out (time).
# 2. actor_clip/driver.sh's look without its actor-only runs (a41, a42): stage 1 of the gpu preset
#    as it is (t) and with stage1.bootstrap=actor stage1.bootstrap_clip=true (c), seeds 41 then 42,
#    each GDNet benchmarked greedily (groups 1-10 x 50, seeds 11-13), two at once, after the trainings.
#    The rule is actor_clip/driver.sh's, unchanged (it compares c with t only); the actor's slow
#    start without the clip is known from "Stage 1 with the actor's bootstrap value" (seeds 21-23).
#    Files go to actor_clip/.  No default changes with this look.
# Every timings.jsonl row now carries peak_device_gib (the allocator's peak so far).
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1 CUDA_VISIBLE_DEVICES=0
unset JAX_COMPILATION_CACHE_DIR
cd $S
RES=/root/res; mkdir -p $RES/warp $RES/clip; log=$RES/machine_log.txt
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader | tr '\n' ' ')" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $RES/$k.txt 2>&1; rc=$?; echo "$k rc=$rc $(( $(date +%s)-t )) s $(date +%T)" >> $log; return $rc; }
keep() { mkdir -p $2; for f in config.json metrics.jsonl timings.jsonl summary.json gate.json; do cp $1/$f $2/ 2>/dev/null; done
         for s in stage2 stage3; do [ -f $1/$s/metrics.jsonl ] && cp $1/$s/metrics.jsonl $2/${s}_metrics.jsonl; done; }
C=/root/cc
# 1. the Warp renderer, pair 34
W=w34b
run train_w34b timeout 900 python train.py --config gpu --set seed=34 camera.renderer=warp camera.render_batch=512 --out /root/runs/w34b --cache-dir $C --json
if [ $? -ne 0 ] && grep -q "out of accelerator memory" $RES/train_w34b.txt; then
  W=w34c
  XLA_PYTHON_CLIENT_MEM_FRACTION=0.95 run train_w34c timeout 900 python train.py --config gpu --set seed=34 camera.renderer=warp camera.render_batch=512 --out /root/runs/w34c --cache-dir $C --json
fi
keep /root/runs/$W $RES/warp/$W
E="--seeds 11,12,13 --cache-dir $C"
if [ -f /root/runs/$W/summary.json ]; then
( export XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=0.45
  run vags_$W python eval.py --run /root/runs/$W $E --out "$RES/warp/$W/seed{seed}/eval_vags.json" &
  run abl_$W python eval.py --run /root/runs/$W --no-viewpoint $E --out "$RES/warp/$W/seed{seed}/eval_vags-no-viewpoint.json" &
  wait )
fi
# 2. stage 1 with the actor's values clipped
declare -A SET=([t]="" [c]="stage1.bootstrap=actor stage1.bootstrap_clip=true")
for SEED in 41 42; do
  for K in t c; do
    run train_$K$SEED timeout 600 python train.py --config gpu --stage gdnet --set seed=$SEED ${SET[$K]} --out /root/runs/$K$SEED --cache-dir $C --json
    keep /root/runs/$K$SEED $RES/clip/$K$SEED
  done
done
for SEED in 41 42; do
  for R in t$SEED c$SEED; do
    XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=0.45 \
      run eval_$R python eval.py --run /root/runs/$R $E --out "$RES/clip/$R/seed{seed}/eval_gdnet.json" &
  done
  wait
done
echo "done $(date +%T)" >> $log
