#!/usr/bin/env bash
# Issue 27: stage 1 with the bootstrap value stored by the actor (stage1.bootstrap=actor) against
# the target network's pass at every update (the preset), side by side on one bare H200.
# Per training seed (21, then 22): train.py --stage gdnet of the gpu preset, first as it is, then
# with stage1.bootstrap=actor; each stage-1 run's GDNet is then benchmarked greedily (eval.py's
# gdnet policy), groups 1-10 x 50 rounds, seeds 11-13.  Last, if the machine is still held,
# bench/train_throughput.py's breakdown of one iteration, both ways.
# Fixed before anything ran (bench/RESULTS.md, "Stage 1 with the actor's bootstrap value"):
# - Speed: grasp attempts/s over the chunks after the first (metrics.jsonl's wall_s), per pair.
# - Learning: success over the same attempts (train.py's per-iteration success, in quarters of
#   the stage) and the benchmark's success and clearing, per pair.
# - No default changes with this look: the option stays off in every preset.  A later look may
#   make it the gpu preset's if, on both pairs, it is at least 1.3x as fast and its GDNet's
#   benchmark success (mean of seeds 11-13) is no more than 1 point below the preset's; a change
#   of default would then need the whole pipeline benchmarked (VAGS and its ablation).
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
cd $S
C=/root/cc
O=/root/out; log=$O/machine_log.txt; mkdir -p $O
run() { k=$1; shift; t=$(date +%s); "$@" > $O/$k.txt 2>&1; rc=$?; echo "$k rc=$rc $(( $(date +%s)-t )) s $(date +%T)" >> $log; return $rc; }
keep() { mkdir -p $O/$2; cp $1/*.json $1/*.jsonl $O/$2/ 2>/dev/null; }
ev() { XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=0.45 run "$@"; }
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
for SEED in 21 22; do
  run train_t$SEED timeout 700 python train.py --config gpu --stage gdnet --set seed=$SEED --out /root/runs/t$SEED --cache-dir $C --json
  keep /root/runs/t$SEED t$SEED
  run train_a$SEED timeout 700 python train.py --config gpu --stage gdnet --set seed=$SEED stage1.bootstrap=actor --out /root/runs/a$SEED --cache-dir $C --json
  keep /root/runs/a$SEED a$SEED
done
for SEED in 21 22; do
  for R in t$SEED a$SEED; do
    ev eval_$R python eval.py --run /root/runs/$R --seeds 11,12,13 --cache-dir $C --out "$O/$R/seed{seed}/eval_gdnet.json" &
  done
  wait
done
run tp_target timeout 500 python bench/train_throughput.py --config gpu --trunks small --no-parts --cache-dir $C --out $O/tp_target.json
run tp_actor timeout 500 python bench/train_throughput.py --config gpu --trunks small --no-parts --set stage1.bootstrap=actor --cache-dir $C --out $O/tp_actor.json
echo "done $(date +%T)" >> $log
