#!/usr/bin/env bash
# Written on 2026-12-07 before its device call; run on the same machine after driver.sh and
# bench/results/throughput/physics_settle/driver.sh, on driver.sh's runs and compile cache.
# Issue 23, items 1 and 5, measured again on two new trainings: bench/gate_headroom.py on each
# run's own gate table (VANet's move against a move to a random object cell, and the oracle, on
# the same states).  A diagnostic only: it decides nothing.
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1 CUDA_VISIBLE_DEVICES=0
cd $S
RES=/root/res/headroom C=/root/cc
source bench/driver_lib.sh
start_log
for s in 50 51; do
  mkdir -p $RES/r$s; [ -f /root/runs/r$s/gate.json ] && run headroom_r$s timeout 200 python bench/gate_headroom.py \
    --run /root/runs/r$s --cache-dir $C --out $RES/r$s/headroom.json
done
echo "done $(date +%T)" >> $RES/machine_log.txt
