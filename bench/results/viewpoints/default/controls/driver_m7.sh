#!/usr/bin/env bash
# Two GPUs: (A, GPU 0) issue 23's rate gate on the two trained runs: the gate table, then VAGS with
# it on seeds 11-13; (B, GPU 1) stage 1 on one GPU, then (after A) stage 1 data parallel on both.
cd "$(dirname "$0")/.."
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
O=runs/o7; log=runs/m7.log; mkdir -p $O
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader | tr '\n' ' ')" > $log
(
  export CUDA_VISIBLE_DEVICES=0
  for R in vp warm; do
    t0=$(date +%s); python -m vags_jax.stages.gate_measure --run runs/$R --worlds 256 --steps 4 > $O/$R.gate.txt 2>&1
    echo "$R gate rc=$? $(( $(date +%s) - t0 )) s $(date +%T)" >> $log; cp runs/$R/gate.json $O/$R.gate.json
  done
  for R in vp warm; do
    t0=$(date +%s); python eval.py --run runs/$R --set vags.gate=rate --seeds 11,12,13 --cache-dir /root/cc0 \
      --out "$O/$R/seed{seed}/eval_vags-rate.json" > $O/$R.vags-rate.txt 2>&1
    echo "$R vags-rate rc=$? $(( $(date +%s) - t0 )) s $(date +%T)" >> $log
  done
  touch runs/a_done
) &
(
  export CUDA_VISIBLE_DEVICES=1
  t0=$(date +%s); python train.py --config gpu --stage gdnet --out runs/dp1 --set stage1.iterations=48 --cache-dir /root/cc1 --quiet --json > $O/dp1.log 2>&1
  echo "dp1 rc=$? $(( $(date +%s) - t0 )) s $(date +%T)" >> $log
  while [ ! -f runs/a_done ]; do sleep 5; done
  export CUDA_VISIBLE_DEVICES=0,1
  t0=$(date +%s); python train.py --config gpu --stage gdnet --devices 2 --out runs/dp2 --set stage1.iterations=48 stage1.n_worlds=1024 --cache-dir /root/cc2 --quiet --json > $O/dp2.log 2>&1
  echo "dp2 rc=$? $(( $(date +%s) - t0 )) s $(date +%T)" >> $log
  for d in dp1 dp2; do cp runs/$d/metrics.jsonl $O/$d.metrics.jsonl; cp runs/$d/timings.jsonl $O/$d.timings.jsonl; cp runs/$d/summary.json $O/$d.summary.json; done
) &
wait
touch runs/m7_done
