#!/usr/bin/env bash
# Queued after driver.sh (same machine, caches warm): second trainings, seed 1, no sweeps:
#   g61: the gpu preset as it is; g63: with vags.train_close_score=success.
# Rule 1 of driver.sh then reads "on g60 and g61", rule 2 "g62 and g63 against g60 and g61"
# (mean 6-10 margin over the six seeds at least 3 points higher, success not more than 1 lower).
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
cd $S
L=/root/runs/machine_log.txt
while ! grep -q "^done" $L; do sleep 2; done
echo "start2 $(date +%T)" >> $L
bash /root/chain.sh 0 61 1 q &
bash /root/chain.sh 1 63 1 success &
wait
echo "done2 $(date +%T)" >> $L
