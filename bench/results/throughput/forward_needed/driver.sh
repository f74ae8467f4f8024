#!/usr/bin/env bash
# Issue 27: Q-network passes only where their result is used (net.forward_needed_only), against the
# `gpu` preset, on ONE bare H100 (or H200) in one session (about 17 minutes after the wheels).
# Ran 2026-12-06, 19:22-19:37 UTC, on one bare H100, as below (bench/RESULTS.md, "Q-network passes
# only where their result is used").
# Two whole pipelines of the same seed, one after the other: e38 (the preset; it compiles from an
# empty cache) and n38 (the same with net.forward_needed_only=true: its stage programs compile anew,
# Warp's kernels are cached).  The speed figure is each stage's milliseconds per iteration after its first chunk
# (no compiling in them), from metrics.jsonl; then both runs' VAGS and ablation (groups 1-10 x 50
# rounds, seeds 11-13), two evaluations at once, to check that the learning is the same.
# Fixed before the run: the preset takes the flag if stage 1's milliseconds per iteration are lower
# with it, stages 2 and 3 together (their seconds after the first chunk) are not slower, and VAGS
# and the ablation are each within 2 points (the benchmark's spread between trainings of one
# command is about that large).
# Poll with: bash /root/src/bench/results/throughput/forward_needed/poll.sh 560 /root/res/machine_log.txt
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1 CUDA_VISIBLE_DEVICES=0
unset JAX_COMPILATION_CACHE_DIR
cd $S
RES=/root/res; mkdir -p $RES; log=$RES/machine_log.txt
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader | tr '\n' ' ')" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $RES/$k.txt 2>&1; rc=$?; echo "$k rc=$rc $(( $(date +%s)-t )) s $(date +%T)" >> $log; return $rc; }
keep() { mkdir -p $2; for f in config.json metrics.jsonl timings.jsonl summary.json gate.json compile_ahead.log compile_ahead_gate.log; do cp $1/$f $2/ 2>/dev/null; done
         for s in stage2 stage3; do [ -f $1/$s/metrics.jsonl ] && cp $1/$s/metrics.jsonl $2/${s}_metrics.jsonl; done; }
C=/root/cc
declare -A SET=([e]="" [n]="net.forward_needed_only=true")
ev() { XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=0.45 run "$@"; }
E="--seeds 11,12,13 --cache-dir $C"
for K in e n; do
  run train_${K}38 timeout 600 python train.py --config gpu --set seed=38 ${SET[$K]} --out /root/runs/${K}38 --cache-dir $C --json
  keep /root/runs/${K}38 $RES/${K}38
done
for K in e n; do
  R=${K}38
  [ -f /root/runs/$R/summary.json ] || continue
  ev vags_$R python eval.py --run /root/runs/$R $E --out "$RES/$R/seed{seed}/eval_vags.json" &
  ev abl_$R python eval.py --run /root/runs/$R --no-viewpoint $E --out "$RES/$R/seed{seed}/eval_vags-no-viewpoint.json" &
  wait
done
echo "done $(date +%T)" >> $log
