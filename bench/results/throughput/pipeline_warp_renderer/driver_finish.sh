#!/usr/bin/env bash
# Issue 27: completes driver_1gpu.sh's rule on ONE bare H200 (about 12 minutes with a cold cache).
# On 2026-11-29 the Warp side of pair 34 (w34) trained, but its benchmark was cut by the machine
# time and the run was lost with the machine.  This trains it again (same command, same seed,
# alone on the GPU), benchmarks it as VAGS and its ablation (groups 1-10 x 50 rounds, seeds 11-13,
# the two evaluations at once), then runs what driver_1gpu.sh dropped: bench/trunk_speed.py alone
# (its streams_s2d_folded_depth1 form, the depth stream's first layer over one channel) and
# bench/train_throughput.py's stage-3 phases of this Warp run.
# The rule is driver_1gpu.sh's, unchanged, with pair 34's Warp side (stage 1's first quarter and
# the benchmark) taken from this training; t34, t35 and w35 are the files of 2026-11-29.
# /root/res is copied to finish/ in this directory; tables.py then uses finish/w34b for pair 34.
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1 CUDA_VISIBLE_DEVICES=0
unset JAX_COMPILATION_CACHE_DIR
cd $S
RES=/root/res; mkdir -p $RES; log=$RES/machine_log.txt
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader | tr '\n' ' ')" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $RES/$k.txt 2>&1; rc=$?; echo "$k rc=$rc $(( $(date +%s)-t )) s $(date +%T)" >> $log; return $rc; }
R=/root/runs/w34b; C=/root/cc1
run train_w34b timeout 1000 python train.py --config gpu --set seed=34 camera.renderer=warp camera.render_batch=512 --out $R --cache-dir $C --json
mkdir -p $RES/w34b; for f in config.json metrics.jsonl timings.jsonl summary.json gate.json; do cp $R/$f $RES/w34b/ 2>/dev/null; done
for s in stage2 stage3; do [ -f $R/$s/metrics.jsonl ] && cp $R/$s/metrics.jsonl $RES/w34b/${s}_metrics.jsonl; done
E="--seeds 11,12,13 --cache-dir $C"
( export XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=0.45
  run vags_w34b python eval.py --run $R $E --out "$RES/w34b/seed{seed}/eval_vags.json" &
  run abl_w34b python eval.py --run $R --no-viewpoint $E --out "$RES/w34b/seed{seed}/eval_vags-no-viewpoint.json" &
  wait )
run trunk_speed timeout 300 python bench/trunk_speed.py --batches 1024 --reps 10 --out $RES/trunk_speed.json
run tp_stage3 timeout 400 python bench/train_throughput.py --run $R --stage stage3 --trunks small --no-parts --cache-dir $C --out $RES/tp_stage3_w34b.json
echo "done $(date +%T)" >> $log
