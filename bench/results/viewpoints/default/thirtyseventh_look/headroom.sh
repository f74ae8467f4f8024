#!/usr/bin/env bash
# Written on 2026-12-07 AFTER driver.sh had run, and run by hand in the next device call on the
# same machine, on driver.sh's runs and compile cache (the one-line command of that call, unrolled).
# Issue 23, items 1 and 5, on two trainings made with vags.direct_score=q_mean:
# bench/gate_headroom.py on each run's own gate table.  A diagnostic only: it decides nothing.
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1 CUDA_VISIBLE_DEVICES=0
cd $S
mkdir -p /root/res/headroom
for s in 52 53; do
  mkdir -p /root/res/headroom/q$s
  /usr/bin/time -f "headroom_q$s %e s" timeout 200 python bench/gate_headroom.py --run /root/runs/q$s \
    --cache-dir /root/cc --out /root/res/headroom/q$s/headroom.json > /root/res/headroom/headroom_q$s.txt 2>&1
done
