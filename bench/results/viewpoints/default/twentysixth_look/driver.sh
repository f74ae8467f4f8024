#!/usr/bin/env bash
# Issue 23, twenty-sixth look (a bare 2 x H200 machine; no 4-GPU machine was lent): two
# trainings at once, one per GPU, both seed 0:
#   g60: the gpu preset as it is (vags.close_score=success; training scores its grasps after a
#        move with "q");
#   g62: the same with vags.train_close_score=success (training scores them by the success net).
# Each run: the ablation, VAGS, and VAGS capped at a motion number of 1.3 (seeds 11-13, groups
# 1-10 x 50 rounds), then the Fig. 6 sweep (seed 11, 20 rounds, 11 points).
# Rules fixed before running:
#  1. vags.max_motion_number=1.3 becomes the gpu default if, on g60, the capped VAGS has a
#     motion number below 1.35 and is at least 5 points above its ablation on 6-10 objects, on
#     every seed.
#  2. vags.train_close_score=success becomes the gpu default if, under the setting rule 1
#     gives, g62's mean 6-10 margin over its three seeds is at least 3 points above g60's (the
#     spread between two trainings of one config last look: +11.5 against +8.6) and its mean
#     overall success is not more than 1 point lower.
#  The final run is g60, or g62 if rule 2 holds.
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
cd $S
mkdir -p /root/runs; L=/root/runs/machine_log.txt
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader | tr '\n' ' ')" > $L
bash /root/chain.sh 0 60 0 q sweep &
bash /root/chain.sh 1 62 0 success sweep &
wait
echo "done $(date +%T)" >> $L
