#!/usr/bin/env bash
# RUN on one H100 on 2026-12-07, 03:31-03:44 UTC (its results beside this file; `tables.py` prints
# them).  f41, its evaluations and its sweep finished, then w42.  Six starts had failed first, so
# 191 s of device time were left for w43, which takes about 260 s: the machine was given back as w43
# started (train_w43_auto.txt is its log up to there), and the warm pair is half measured.
# Written in the session of 2026-12-06 23:25 to 2026-12-07 02:25 UTC, in which no H100 or H200
# could be started.
# Issue 23: the final run trained again with today's `gpu` preset (MJX's Warp renderer and
# net.forward_needed_only, both taken after g60 was trained), its VAGS and ablation (groups 1-10 x
# 50 rounds, seeds 11-13) and its Fig. 6 sweep (seed 11, 20 rounds a group, 11 thresholds).
# Issue 27: the compile-ahead child's cost on a warm cache, one pair of warm pipelines.
# On ONE bare H100 (or H200), after the wheels.
#
# Fixed before the run:
# * f41 (seed 41, compiled from an empty cache) becomes issue 23's final run whatever its figures:
#   its reports replace g60's at bench/results/viewpoints/default/seed<S>/ (g60's stay, gzipped,
#   in twentysixth_look/g60/), and its sweep is the Fig. 6 plot, because g60 was trained by a
#   preset that no longer exists (the ray caster, every Q-network pass run).  If its evaluations
#   do not all finish, g60 stays the final run.
# * w42 (seed 42, --compile-ahead off) and then w43 (seed 43, the default "auto": the child runs)
#   from f41's cache: their train.py and stage times are reported as measured.  One pair is one
#   observation, so no default changes on it.
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
run train_f41 timeout 700 python train.py --config gpu --set seed=41 --out /root/runs/f41 --cache-dir $C --json
keep /root/runs/f41 $RES/f41
if [ -f /root/runs/f41/summary.json ]; then
  ev vags_f41 python eval.py --run /root/runs/f41 $E --out "$RES/f41/seed{seed}/eval_vags.json" &
  ev abl_f41 python eval.py --run /root/runs/f41 --no-viewpoint $E --out "$RES/f41/seed{seed}/eval_vags-no-viewpoint.json" &
  ev sweep_f41 python eval.py --run /root/runs/f41 --seed 11 --rounds 20 --threshold-sweep=-0.25:0.25:0.05 --cache-dir $C --out "$RES/f41/sweep/eval_vags_r20.json" &
  wait
fi
echo "evals done $(date +%T)" >> $log
run train_w42_off timeout 600 python train.py --config gpu --set seed=42 --out /root/runs/w42 --cache-dir $C --json --compile-ahead off
keep /root/runs/w42 $RES/w42
run train_w43_auto timeout 600 python train.py --config gpu --set seed=43 --out /root/runs/w43 --cache-dir $C --json
keep /root/runs/w43 $RES/w43
echo "done $(date +%T)" >> $log
