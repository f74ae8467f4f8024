#!/usr/bin/env bash
# Issue 27, prepared 2026-12-06 (a first, one-run version of this file was committed for the ~12
# device minutes left after actor_clip/driver_control.sh; no machine could be started for it).
# Ran 2026-12-06, 17:21-17:37 UTC, on one bare H100, as below: pair 36 only (DEADLINE left pair 37
# out); bench/RESULTS.md, "The whole pipeline with stage 1's clipped actor values".  For ONE bare H100 (or H200) and a whole 30-minute budget (about 24 minutes with a cold
# cache): the step actor_clip/driver_control.sh's header asks for before any preset takes stage 1's
# clipped actor values.
# Changed before its first run (2026-12-06, 17:00 UTC; 22 device minutes left after three refused
# starts, too few for both pairs):
# - pair 36 runs first with c36 BEFORE p36: c36 compiles from an empty cache and p36 finds GG-CNN's
#   and stages 2-3's programs cached, so the wall-clock criterion, now judged on pair 36, can only
#   favour the preset; pair 37 (p37, then c37) runs only if DEADLINE (epoch seconds, when given)
#   leaves 640 s for it, else in a later session (the rule then waits for it);
# - each pair is evaluated as soon as it is trained, its runs' two evaluations at once (as in
#   h100_finish/driver.sh).
# After that run (for pair 37's): keep() also keeps the compile-ahead children's logs (p36's
# stage-2 child ended with exit code 1, and its log was not kept).
# Two pairs on one GPU: p<S> (train.py --config gpu --set seed=S, the preset) and c<S> (the same with
#   stage1.bootstrap=actor stage1.bootstrap_clip=true), S = 36, 37; each run's VAGS and ablation
#   (groups 1-10 x 50 rounds, seeds 11-13).
# Fixed before any run; the preset takes the clip only if all four hold:
# - VAGS: c's success no more than 1 point below p's, averaged over both pairs and seeds 11-13;
# - the ablation (GDNet alone): likewise no more than 1 point below on average;
# - stage 1's first-quarter success: no more than 2 points below on average;
# - train.py's wall clock: c36 (cold) below p36 (after it).
# If a run fails, no default changes.  Files go to this directory (p<S>/, c<S>/); tables.py prints the
# tables and the verdict (checked on a stand-in copy of other runs before this driver ran).
# Poll with: bash /root/src/bench/results/throughput/actor_clip/poll.sh 560 /root/res/machine_log_pipeline.txt
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1 CUDA_VISIBLE_DEVICES=0
unset JAX_COMPILATION_CACHE_DIR
cd $S
RES=/root/res; mkdir -p $RES; log=$RES/machine_log_pipeline.txt
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader | tr '\n' ' ')" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $RES/$k.txt 2>&1; rc=$?; echo "$k rc=$rc $(( $(date +%s)-t )) s $(date +%T)" >> $log; return $rc; }
keep() { mkdir -p $2; for f in config.json metrics.jsonl timings.jsonl summary.json gate.json compile_ahead.log compile_ahead_gate.log; do cp $1/$f $2/ 2>/dev/null; done
         for s in stage2 stage3; do [ -f $1/$s/metrics.jsonl ] && cp $1/$s/metrics.jsonl $2/${s}_metrics.jsonl; done; }
C=/root/cc
declare -A SET=([p]="" [c]="stage1.bootstrap=actor stage1.bootstrap_clip=true")
ev() { XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=0.45 run "$@"; }
E="--seeds 11,12,13 --cache-dir $C"
for SEED in 36 37; do
  ORDER="c p"; [ $SEED = 37 ] && ORDER="p c"
  if [ $SEED = 37 ] && [ -n "$DEADLINE" ] && [ $(( $(date +%s) + 640 )) -gt $DEADLINE ]; then
    echo "pair 37 left for a later session (DEADLINE $DEADLINE, now $(date +%s))" >> $log; break
  fi
  for K in $ORDER; do
    run train_$K$SEED timeout 600 python train.py --config gpu --set seed=$SEED ${SET[$K]} --out /root/runs/$K$SEED --cache-dir $C --json
    keep /root/runs/$K$SEED $RES/$K$SEED
  done
  for K in $ORDER; do
    R=$K$SEED
    [ -f /root/runs/$R/summary.json ] || continue
    ev vags_$R python eval.py --run /root/runs/$R $E --out "$RES/$R/seed{seed}/eval_vags.json" &
    ev abl_$R python eval.py --run /root/runs/$R --no-viewpoint $E --out "$RES/$R/seed{seed}/eval_vags-no-viewpoint.json" &
    wait
  done
done
echo "done $(date +%T)" >> $log
