#!/usr/bin/env bash
# Issue 27, 2026-12-06, on ONE bare H100 with the ~12 minutes of device time left after
# actor_clip/driver_control.sh: a first look, outside any rule, at the whole `gpu` pipeline with
# stage 1's actor values clipped (stage1.bootstrap=actor stage1.bootstrap_clip=true), the step
# driver_control.sh's header asks for before any preset takes them.
# One training, seed 35, from an empty compile cache, then VAGS and its ablation (groups 1-10 x 50
# rounds, seeds 11-13, both at once under a 0.45 cap as w34b's were).  Its pair is w35h
# (pipeline_warp_renderer/finish/w35h: the same preset and seed on an H100 of 2026-12-06, warm):
# its learning compares; its wall clock does not (cold here, warm there; not side by side).
# One pair cannot decide a default, so none changes with this look, whatever it shows.
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1 CUDA_VISIBLE_DEVICES=0
unset JAX_COMPILATION_CACHE_DIR
cd $S
RES=/root/res; mkdir -p $RES; log=$RES/machine_log_pipeline.txt
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader | tr '\n' ' ')" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $RES/$k.txt 2>&1; rc=$?; echo "$k rc=$rc $(( $(date +%s)-t )) s $(date +%T)" >> $log; return $rc; }
keep() { mkdir -p $2; for f in config.json metrics.jsonl timings.jsonl summary.json gate.json; do cp $1/$f $2/ 2>/dev/null; done
         for s in stage2 stage3; do [ -f $1/$s/metrics.jsonl ] && cp $1/$s/metrics.jsonl $2/${s}_metrics.jsonl; done; }
C=/root/cc
run train_c35 timeout 600 python train.py --config gpu --set seed=35 stage1.bootstrap=actor stage1.bootstrap_clip=true --out /root/runs/c35 --cache-dir $C --json
keep /root/runs/c35 $RES/c35
E="--seeds 11,12,13 --cache-dir $C"
if [ -f /root/runs/c35/summary.json ]; then
( export XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=0.45
  run vags_c35 python eval.py --run /root/runs/c35 $E --out "$RES/c35/seed{seed}/eval_vags.json" &
  run abl_c35 python eval.py --run /root/runs/c35 --no-viewpoint $E --out "$RES/c35/seed{seed}/eval_vags-no-viewpoint.json" &
  wait )
fi
echo "done $(date +%T)" >> $log
