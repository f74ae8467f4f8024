#!/usr/bin/env bash
# Written on 2026-12-07, before the device call that runs it, after the default became
# benchmark.redrop_spilled = null (10 re-drops on pile scenes).  Does the default do its job on the
# edge scene variant (eval.py --scenes edge: drop positions 3.5 cm inside the workspace edge, so
# more objects spill, and a re-drop from the same pose may spill again)?  The heuristic on groups
# 6-10 x 50, seeds 11-13, with the default and with --set benchmark.redrop_spilled=0, two at once on
# an empty cache.  No default depends on it; it is reported either way.
# Poll with: bash /root/src/bench/results/throughput/forward_needed/poll.sh 200 /root/res/machine_log.txt
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1 CUDA_VISIBLE_DEVICES=0
unset JAX_COMPILATION_CACHE_DIR
cd $S
RES=/root/res C=/root/cc
source bench/driver_lib.sh
start_log
H="--config gpu --scenes edge --policy heuristic --groups 6,7,8,9,10 --rounds 50 --seeds 11,12,13 --cache-dir $C"
ev edge_default python eval.py $H --out "$RES/edge/default/seed{seed}/eval_heuristic.json" &
ev edge_d0 python eval.py $H --set benchmark.redrop_spilled=0 --out "$RES/edge/d0/seed{seed}/eval_heuristic.json" &
wait
echo "done $(date +%T)" >> $RES/machine_log.txt
