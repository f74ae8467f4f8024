#!/usr/bin/env bash
# Issue 27: does clipping the actor's stored values (stage1.bootstrap_clip) remove the actor's slow
# start?  Stage 1 of the gpu preset three ways, one after the other on ONE bare H200, per training
# seed (41, then 42): as it is (t, the target network's pass at every update), with
# stage1.bootstrap=actor (a), and with stage1.bootstrap=actor stage1.bootstrap_clip=true (c).
# Each stage-1 run's GDNet is then benchmarked greedily (eval.py's gdnet policy), groups 1-10 x 50
# rounds, seeds 11-13, three evaluations at once.  About 15 minutes from a bare machine.
# Fixed before anything ran (bench/RESULTS.md, the section this run's results go to; the earlier
# looks: "Stage 1 with the actor's bootstrap value", whose actor learnt 8.1-13.4 points worse in
# its first quarter and 7.3-21.0 in its second):
# - Learning: train.py's per-iteration success in quarters of the stage (0-29, 30-59, 60-89,
#   90-119), and the GDNet's benchmark success (mean of seeds 11-13).
# - Speed: grasp attempts/s over the chunks after the first.
# - The clip removes the slow start if, averaged over both seeds, c's success in each of the first
#   two quarters is no more than 2 points below t's, and on both seeds c's benchmark success is no
#   more than 1 point below t's.  No default changes with this look; if met, a later look runs
#   the whole pipeline with the two settings (VAGS and its ablation) before any preset takes them.
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1 CUDA_VISIBLE_DEVICES=0
unset JAX_COMPILATION_CACHE_DIR
cd $S
C=/root/cc
RES=/root/res; log=$RES/machine_log.txt; mkdir -p $RES
run() { k=$1; shift; t=$(date +%s); "$@" > $RES/$k.txt 2>&1; rc=$?; echo "$k rc=$rc $(( $(date +%s)-t )) s $(date +%T)" >> $log; return $rc; }
keep() { mkdir -p $RES/$2; cp $1/*.json $1/*.jsonl $RES/$2/ 2>/dev/null; }
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
declare -A SET=([t]="" [a]="stage1.bootstrap=actor" [c]="stage1.bootstrap=actor stage1.bootstrap_clip=true")
for SEED in 41 42; do
  for K in t a c; do
    run train_$K$SEED timeout 700 python train.py --config gpu --stage gdnet --set seed=$SEED ${SET[$K]} --out /root/runs/$K$SEED --cache-dir $C --json
    keep /root/runs/$K$SEED $K$SEED
  done
done
for SEED in 41 42; do
  for K in t a c; do
    R=$K$SEED
    XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=0.3 \
      run eval_$R python eval.py --run /root/runs/$R --seeds 11,12,13 --cache-dir $C --out "$RES/$R/seed{seed}/eval_gdnet.json" &
  done
  wait
done
echo "done $(date +%T)" >> $log
