#!/usr/bin/env bash
# Started by hand at 11:16 UTC after train_w34 ran out of memory beside train_t34 (driver_1gpu.sh
# capped each at 0.45 of the GPU; the Warp run's stage-1 chunk asked for 26.6 GiB more).  Waits for
# driver_1gpu.sh's four pair-35 evaluations, stops the driver there (trunk_speed and tp_stage3 are
# dropped: no device time is left for them), then trains w34 ALONE (learning figures only) and
# benchmarks it like the others.
S=/root/src; RES=/root/res; log=$RES/machine_log.txt
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1 CUDA_VISIBLE_DEVICES=0
unset JAX_COMPILATION_CACHE_DIR
cd $S
while [ $(grep -cE '^(vags|abl)_(t|w)35 ' $log) -lt 4 ]; do sleep 5; done
pkill -f driver_1gpu.sh; pkill -f trunk_speed.py; pkill -f train_throughput.py; sleep 2
run() { k=$1; shift; t=$(date +%s); "$@" > $RES/$k.txt 2>&1; rc=$?; echo "$k rc=$rc $(( $(date +%s)-t )) s $(date +%T)" >> $log; return $rc; }
R=/root/runs/w34; rm -rf $R
run train_w34 timeout 1000 python train.py --config gpu --set seed=34 camera.renderer=warp camera.render_batch=512 --out $R --cache-dir /root/cc1 --json
mkdir -p $RES/w34; for f in config.json metrics.jsonl timings.jsonl summary.json gate.json; do cp $R/$f $RES/w34/ 2>/dev/null; done
for s in stage2 stage3; do [ -f $R/$s/metrics.jsonl ] && cp $R/$s/metrics.jsonl $RES/w34/${s}_metrics.jsonl; done
E="--seeds 11,12,13 --cache-dir /root/cc1"
export XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=0.45
run vags_w34 python eval.py --run $R $E --out "$RES/w34/seed{seed}/eval_vags.json" &
run abl_w34 python eval.py --run $R --no-viewpoint $E --out "$RES/w34/seed{seed}/eval_vags-no-viewpoint.json" &
wait
echo "done $(date +%T)" >> $log
