#!/usr/bin/env bash
# Issue 23: a fresh gpu pipeline (which now measures the rate gate's table after stage 3), then VAGS with
# the success gate, with the rate gate, and without VANet, seeds 11-13, the three evaluations side by side.
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
O=runs/o8; R=runs/r8; log=runs/m8.log; mkdir -p $O
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
t0=$(date +%s); python train.py --config gpu --out $R --cache-dir /root/cc-train --quiet --json > $O/train.txt 2>&1
echo "train rc=$? $(( $(date +%s) - t0 )) s $(date +%T)" >> $log
cp $R/config.json $R/timings.jsonl $R/summary.json $R/gate.json $R/metrics.jsonl $O/ 2>/dev/null
cp $R/stage2/metrics.jsonl $O/stage2_metrics.jsonl; cp $R/stage3/metrics.jsonl $O/stage3_metrics.jsonl
export XLA_PYTHON_CLIENT_MEM_FRACTION=0.3
for pol in vags vags-rate vags-no-viewpoint; do
  (
    flag=""; [ $pol = vags-rate ] && flag="--set vags.gate=rate"; [ $pol = vags-no-viewpoint ] && flag="--no-viewpoint"
    t1=$(date +%s); python eval.py --run $R $flag --seeds 11,12,13 --cache-dir /root/cc-$pol --out "$O/seed{seed}/eval_$pol.json" > $O/$pol.txt 2>&1
    echo "$pol rc=$? $(( $(date +%s) - t1 )) s $(date +%T)" >> $log
  ) &
done
wait
touch runs/m8_done
