#!/usr/bin/env bash
# Written on 2026-12-07, before any device call that runs it.
# Issue 23: does VAGS under `vags.direct_score=q_mean` meet the issue's goals against its OWN
# ablation?  In the thirty-fifth and thirty-sixth looks the q_mean ablation ran on the original
# run, whose q table had picked the other stage's GDNet on three of four trainings, so the
# margin and clearing goals of r48m, r50m and r51m were not measured (bench/RESULTS.md,
# "thirty-sixth look").  Here the whole pipeline runs with q_mean, so its table is measured with
# it and picks the GDNet that VAGS and `--no-viewpoint` both play.  Two new trainings, seeds 52
# and 53; groups 1-10 x 50 rounds, seeds 11-13.  A measurement: it changes no default (the rule
# for q_mean as the default was not met in the thirty-sixth look).  Reported whatever it shows,
# with `python bench/viewpoint_goals.py DIR --goals` on each run.
# On ONE bare H100 (or H200), after the wheels.  About 14 minutes.
# Poll with: bash /root/src/bench/results/throughput/forward_needed/poll.sh 560 /root/res/machine_log.txt
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1 CUDA_VISIBLE_DEVICES=0
unset JAX_COMPILATION_CACHE_DIR
cd $S
RES=/root/res C=/root/cc
source bench/driver_lib.sh
start_log
E="--seeds 11,12,13 --cache-dir $C"

for seed in 52 53; do
  R=/root/runs/q$seed O=$RES/q$seed
  run train_q$seed timeout 700 python train.py --config gpu --set seed=$seed vags.direct_score=q_mean --out $R \
    --cache-dir $C --json
  keep $R $O
  [ -f $R/gate.json ] || continue
  ev vags_q$seed python eval.py --run $R $E --out "$O/seed{seed}/eval_vags.json" &
  ev abl_q$seed python eval.py --run $R --no-viewpoint $E --out "$O/seed{seed}/eval_vags-no-viewpoint.json" &
  wait
  echo "q$seed done $(date +%T)" >> $RES/machine_log.txt
done
echo "done $(date +%T)" >> $RES/machine_log.txt
