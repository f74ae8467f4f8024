#!/usr/bin/env bash
# Written on 2026-12-07 before any device call of its session.
# Issue 23: GDNet's direct grasp on the mean of its two views of each grasp
# (`vags.direct_score=q_mean`, new: the argmax of the mean of Q at rotations r and r + 8 of 16,
# the same parallel-jaw grasp seen on heightmaps rotated 180 degrees apart).  Last session's
# two-by-two showed the argmax gaining 1.4 points from GDNet's second view of each grasp; this
# asks whether averaging the two views gains more than taking the larger.
# 1. r48: a fresh `gpu` pipeline (seed 48, never used before), from an empty compile cache.
# 2. r48m: a copy of r48 whose gate table is measured again with the new direct grasp
#    (gate_measure --direct-score q_mean; its states also hold GDNet's plain argmax from each
#    state, `gdnet_success`, for a paired comparison of the two direct grasps).
# 3. The benchmark, groups 1-10 x 50 rounds, seeds 11-13, on the same networks: the ablation
#    (GDNet alone) with q and with q_mean; VAGS on r48's table (q) and on r48m's (q_mean).
# 4. If time is left: r49, the same on seed 49 (programs from r48's cache).
# 5. If time is left (issue 27): bench/physics_profile.py at stage 1's 512 worlds and 1,024, the
#    `gpu` physics: our grasp loop's per-step bookkeeping against a bare scan, and an unrolled scan.
# Fixed before the run: no default changes on these runs; the figures are reported whatever
# they are.  A difference is read against the paired standard errors and the seeds' spread.
# On ONE bare H100 (or H200), after the wheels.
# Poll with: bash /root/src/bench/results/throughput/forward_needed/poll.sh 560 /root/res/machine_log.txt
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1 CUDA_VISIBLE_DEVICES=0
unset JAX_COMPILATION_CACHE_DIR
cd $S
RES=/root/res C=/root/cc
source bench/driver_lib.sh
start_log
E="--seeds 11,12,13 --cache-dir $C"
T0=$(date +%s)

look() {  # look SEED: train, measure the q_mean table, the four benchmarks
  local seed=$1 R=/root/runs/r$1 M=/root/runs/r$1m O=$RES/r$1 OM=$RES/r$1m
  run train_r$seed timeout 700 python train.py --config gpu --set seed=$seed --out $R --cache-dir $C --json
  keep $R $O
  [ -f $R/summary.json ] || return 1
  cp -r $R $M
  XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=0.35 \
    run gate_r${seed}m python -m vags_jax.stages.gate_measure --run $M --direct-score q_mean --cache-dir $C &
  ev abl_r$seed python eval.py --run $R --no-viewpoint $E --out "$O/seed{seed}/eval_vags-no-viewpoint.json" &
  ev ablm_r$seed python eval.py --run $R --no-viewpoint --set vags.direct_score=q_mean $E \
    --out "$OM/seed{seed}/eval_vags-no-viewpoint.json" &
  wait
  keep $M $OM
  ev vags_r$seed python eval.py --run $R $E --out "$O/seed{seed}/eval_vags.json" &
  [ -f $M/gate.json ] && ev vagsm_r$seed python eval.py --run $M --set vags.direct_score=q_mean $E \
    --out "$OM/seed{seed}/eval_vags.json" &
  wait
}

look 48
echo "r48 done $(date +%T)" >> $RES/machine_log.txt
# Seed 49 only when at least 9 minutes of the session's ~24 on the machine are left.
if [ $(( $(date +%s) - T0 )) -lt 780 ]; then
  look 49
  echo "r49 done $(date +%T)" >> $RES/machine_log.txt
fi
if [ $(( $(date +%s) - T0 )) -lt 1200 ]; then
  run physics_512 timeout 240 python bench/physics_profile.py --config gpu --worlds 512 1024 --objects 3 --repeats 3 \
    --variant default: --out $RES/physics_profile_512.jsonl
fi
echo "done $(date +%T)" >> $RES/machine_log.txt
