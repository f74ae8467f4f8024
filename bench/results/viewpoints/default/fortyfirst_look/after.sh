#!/usr/bin/env bash
# Written on 2026-12-07, before the device call that runs it.  Issue 27.  Runs on the same warm
# machine right after driver.sh (its log line "done" is the cue):
#  1. one 500-round VAGS table (seed 11) on c56 alone on the warm cache, timed as a whole process,
#     as the fortieth look did on s56 before the program cuts of 4d93038 and 9e4c9df (42.5 s in all,
#     63 programs loaded in 10.1 s); same preset and benchmark, so the difference is those cuts
#     plus the machine's noise;
#  2. bench/results/process_startup/driver.sh (imports by package, backend start, small programs).
# Writes under /root/res/after and appends "done" to /root/res/after/log.txt.
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1 CUDA_VISIBLE_DEVICES=0
unset JAX_COMPILATION_CACHE_DIR
cd $S
RES=/root/res/after C=/root/cc
source bench/driver_lib.sh
start_log
R=/root/runs/c56
if [ -f $R/gate.json ]; then
  run vags_alone bash -c "time python eval.py --run $R --seed 11 --cache-dir $C --out $RES/alone/eval_vags.json"
fi
RES=/root/res/after bash bench/results/process_startup/driver.sh
echo "done $(date +%T)" >> $RES/machine_log.txt
