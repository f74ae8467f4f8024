#!/usr/bin/env bash
# Written on 2026-12-07 before its device call; run on the same machine after the thirty-sixth look
# (bench/results/viewpoints/default/thirtysixth_look/driver.sh), whose compile cache it shares.
# Issue 27: at 512 worlds, does our loop's per-step bookkeeping (pinning parked bodies, the
# overflow check) cost anything against a bare scan of MJX steps, timed over 1 s of simulated
# settle (167 steps at 6 ms) instead of 0.2 s (33 steps, too short: two processes differed by
# 1.3x)?  bench/physics_profile.py --settle-seconds (new), the `gpu` physics, one process.
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1 CUDA_VISIBLE_DEVICES=0
cd $S
RES=/root/res/settle C=/root/cc
source bench/driver_lib.sh
start_log
run settle1 timeout 150 python bench/physics_profile.py --config gpu --worlds 512 --objects 3 --repeats 5 \
  --variant default: --settle-seconds 1.0 --out $RES/settle1.jsonl
echo "done $(date +%T)" >> $RES/machine_log.txt
