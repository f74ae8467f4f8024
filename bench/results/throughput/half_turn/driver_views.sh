#!/usr/bin/env bash
# Written on 2026-12-07 after driver.sh's results, before this second device call of the session.
# driver.sh's half-turn pipelines grasped worse on the benchmark (GDNet alone -6.0 points for h47
# against f47, -3.4 for hd47 against d47) with stage 1's training success close.  A GDNet's
# parameters do not depend on its rotations, so one trained network can act over either set.
# Question: is the loss from training over half a turn, or from acting over one view of each
# grasp instead of two (r and r + 8 are one grasp, judged on heightmaps turned 180 degrees apart,
# and the argmax takes the better)?  Two by two, on stage 1 alone (train.py --stage gdnet):
# trained over 16 whole-turn or 8 half-turn rotations (seeds 47 and 44), each evaluated over both
# (eval.py, GDNet alone, groups 1-10 x 50 rounds, seeds 11-13).
# Fixed before the run: the figures are reported whatever they are; no default changes.
# On ONE bare H100 (or H200), after the wheels.
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1 CUDA_VISIBLE_DEVICES=0
unset JAX_COMPILATION_CACHE_DIR
cd $S
RES=/root/res; mkdir -p $RES; log=$RES/machine_log.txt
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader | tr '\n' ' ')" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $RES/$k.txt 2>&1; rc=$?; echo "$k rc=$rc $(( $(date +%s)-t )) s $(date +%T)" >> $log; return $rc; }
keep() { mkdir -p $2; for f in config.json metrics.jsonl timings.jsonl summary.json; do cp $1/$f $2/ 2>/dev/null; done; }
C=/root/cc
HALF="grasp.n_rotations=8 net.n_rotations=8 grasp.half_turn=true net.half_turn=true"
FULL="grasp.n_rotations=16 net.n_rotations=16 grasp.half_turn=false net.half_turn=false"
ev() { XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=0.3 run "$@"; }
E="--seeds 11,12,13 --cache-dir $C"
for seed in 47 44; do
  for t in full half; do
    over=$FULL; [ $t = half ] && over=$HALF
    run train_s${seed}$t timeout 400 python train.py --config gpu --stage gdnet --set seed=$seed $over --out /root/runs/s${seed}$t --cache-dir $C --json
    keep /root/runs/s${seed}$t $RES/s${seed}$t
  done
  for t in full half; do  # each network acting over both rotation sets, two evaluations at once
    R=/root/runs/s${seed}$t
    [ -f $R/summary.json ] || continue
    ev ev_s${seed}${t}_full python eval.py --run $R $E --set $FULL --out "$RES/s${seed}$t/act_full/seed{seed}/eval_gdnet.json" &
    ev ev_s${seed}${t}_half python eval.py --run $R $E --set $HALF --out "$RES/s${seed}$t/act_half/seed{seed}/eval_gdnet.json" &
    wait
  done
  echo "seed $seed done $(date +%T)" >> $log
done
echo "done $(date +%T)" >> $log
