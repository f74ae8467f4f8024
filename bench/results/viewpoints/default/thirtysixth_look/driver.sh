#!/usr/bin/env bash
# Written on 2026-12-07, a session before any device call that runs it, with the rule it applies
# (bench/RESULTS.md, the thirty-fifth look's "What this means for the issues").
# Issue 23: should `vags.direct_score=q_mean` (GDNet's direct grasp at the argmax of the mean of
# its two views of each grasp) become the `gpu` presets' default?  Two new trainings, r50 and
# r51 (seeds never used), each evaluated with q and with q_mean on the same networks, as the
# thirty-fifth look did:
#   train; copy the run and measure the copy's gate table with --direct-score q_mean; GDNet
#   alone (--no-viewpoint) under q and under q_mean; VAGS on each table; groups 1-10 x 50
#   rounds, seeds 11-13.
# The rule, fixed before these trainings: q_mean becomes the default if GDNet alone grasps at
# least as well under q_mean on at least five of the six seeds, and VAGS's success, averaged
# over the seeds, is not more than 0.5 points lower under q_mean on either training.  The VAGS
# and ablation figures of both planners are reported whatever the outcome.
# On ONE bare H100 (or H200), after the wheels.  About 17 minutes (r50 cold about 7, r51 warm
# about 4.5, each training's table and evaluations about 3.5).
# Poll with: bash /root/src/bench/results/throughput/forward_needed/poll.sh 560 /root/res/machine_log.txt
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1 CUDA_VISIBLE_DEVICES=0
unset JAX_COMPILATION_CACHE_DIR
cd $S
RES=/root/res C=/root/cc
source bench/driver_lib.sh
start_log
E="--seeds 11,12,13 --cache-dir $C"

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

look 50
echo "r50 done $(date +%T)" >> $RES/machine_log.txt
look 51
echo "r51 done $(date +%T)" >> $RES/machine_log.txt
echo "done $(date +%T)" >> $RES/machine_log.txt
