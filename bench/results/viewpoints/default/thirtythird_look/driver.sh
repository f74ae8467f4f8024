#!/usr/bin/env bash
# RUN on one H100 on 2026-12-07, 04:57-05:15 UTC, after five failed starts; every step finished
# (its results beside this file; `tables.py` prints them; bench/RESULTS.md, "thirty-third look").
# Written in the same session before any device call.
# Issue 23: the same-states table the issue asks for, on today's `gpu` preset, which the project
# had not measured since the preset took the rate gate and the success-scored grasp after a move:
# a fresh pipeline f44 (seed 44, from an empty compile cache), then bench/gate_headroom.py on its
# gate table's own states (direct; after VANet's move; after a random object cell's move; the
# direct planner on ground-truth maps), split by the gate's decision and by object count; then
# f44's VAGS and ablation benchmark (groups 1-10 x 50 rounds, seeds 11-13) as a replicate of f41.
# Issue 27: the warm pair w42/w43 left half measured: w45 (default --compile-ahead auto) then w46
# (--compile-ahead off), both from f44's cache on this one machine.
#
# Fixed before the run:
# * f41 stays issue 23's final run: f44 is a replicate, reported beside it, whatever its figures.
# * The warm pair is one observation; no default changes on it.
# On ONE bare H100 (or H200), after the wheels.
# Poll with: bash /root/src/bench/results/throughput/forward_needed/poll.sh 560 /root/res/machine_log.txt
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1 CUDA_VISIBLE_DEVICES=0
unset JAX_COMPILATION_CACHE_DIR
cd $S
RES=/root/res; mkdir -p $RES; log=$RES/machine_log.txt
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader | tr '\n' ' ')" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $RES/$k.txt 2>&1; rc=$?; echo "$k rc=$rc $(( $(date +%s)-t )) s $(date +%T)" >> $log; return $rc; }
keep() { mkdir -p $2; for f in config.json metrics.jsonl timings.jsonl summary.json gate.json gate_states.npz compile_ahead.log compile_ahead_gate.log; do cp $1/$f $2/ 2>/dev/null; done
         for s in stage2 stage3; do [ -f $1/$s/metrics.jsonl ] && cp $1/$s/metrics.jsonl $2/${s}_metrics.jsonl; done; }
C=/root/cc
ev() { XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=0.3 run "$@"; }
E="--seeds 11,12,13 --cache-dir $C"
run train_f44 timeout 700 python train.py --config gpu --set seed=44 --out /root/runs/f44 --cache-dir $C --json
keep /root/runs/f44 $RES/f44
if [ -f /root/runs/f44/summary.json ]; then
  run headroom_f44 python bench/gate_headroom.py --run /root/runs/f44 --cache-dir $C --out $RES/f44/headroom.json
  ev vags_f44 python eval.py --run /root/runs/f44 $E --out "$RES/f44/seed{seed}/eval_vags.json" &
  ev abl_f44 python eval.py --run /root/runs/f44 --no-viewpoint $E --out "$RES/f44/seed{seed}/eval_vags-no-viewpoint.json" &
  wait
fi
echo "evals done $(date +%T)" >> $log
run train_w45_auto timeout 600 python train.py --config gpu --set seed=45 --out /root/runs/w45 --cache-dir $C --json
keep /root/runs/w45 $RES/w45
run train_w46_off timeout 600 python train.py --config gpu --set seed=46 --out /root/runs/w46 --cache-dir $C --json --compile-ahead off
keep /root/runs/w46 $RES/w46
echo "done $(date +%T)" >> $log
