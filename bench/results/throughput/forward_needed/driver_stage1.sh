#!/usr/bin/env bash
# Issue 27, after driver.sh (2026-12-06, 19:22-19:37 UTC): there, each stage 1 ran beside the
# child compiling stage 2's programs ahead (train.py --compile-ahead), which compiled through e38's
# stage 1 but ran out of device memory in n38's, so its stage-1 figures are not clean.  Here stage 1
# alone (train.py --stage gdnet: no child), seed 38, on a fresh H100: the preset (s_e38, compiling
# from an empty cache), then net.forward_needed_only=true (s_n38, its chunk program compiled anew),
# then the preset again on a warm cache (s_e38w) if DEADLINE (epoch seconds) leaves 150 s for it.
# The figure: milliseconds per iteration after the first chunk (tables_stage1.py).
# Ran 2026-12-06, 19:39-19:47 UTC, on a fresh H100 (DEADLINE left room for all three runs).
# Poll with: bash /root/src/bench/results/throughput/forward_needed/poll.sh 580 /root/res/machine_log_stage1.txt
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1 CUDA_VISIBLE_DEVICES=0
unset JAX_COMPILATION_CACHE_DIR
cd $S
RES=/root/res; mkdir -p $RES; log=$RES/machine_log_stage1.txt
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader | tr '\n' ' ')" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $RES/$k.txt 2>&1; rc=$?; echo "$k rc=$rc $(( $(date +%s)-t )) s $(date +%T)" >> $log; return $rc; }
keep() { mkdir -p $2; for f in config.json metrics.jsonl timings.jsonl summary.json; do cp $1/$f $2/ 2>/dev/null; done; }
C=/root/cc
for K in e38 n38 e38w; do
  if [ $K = e38w ] && [ -n "$DEADLINE" ] && [ $(( $(date +%s) + 150 )) -gt $DEADLINE ]; then
    echo "s_e38w left out (DEADLINE $DEADLINE, now $(date +%s))" >> $log; break
  fi
  SET=""; [ $K = n38 ] && SET="net.forward_needed_only=true"
  run train_s_$K timeout 400 python train.py --config gpu --stage gdnet --set seed=38 $SET --out /root/runs/s_$K --cache-dir $C --json
  keep /root/runs/s_$K $RES/s_$K
done
echo "done $(date +%T)" >> $log
