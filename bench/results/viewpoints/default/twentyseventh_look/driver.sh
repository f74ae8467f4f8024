#!/usr/bin/env bash
# Issue 23, twenty-seventh look: the gate table in 16 bins against the preset's 8.
# One bare machine, one pipeline per GPU (a 4 x H200 machine if lent, else 2 x H200):
#   g64 seed 2, g65 seed 3 [, g66 seed 4, g67 seed 5]: train.py --config gpu --set seed=S, as it is.
# Each run R is copied to R16 (links to its networks; gate.json and gate_states.npz copied) and
# refit there over 16 bins from the states its own table was measured on (no simulation).
# Per run, three at once on its GPU (seeds 11-13, groups 1-10 x 50 rounds): the ablation,
# VAGS with the run's 8-bin table, VAGS with R16's 16-bin table. Then seeds 14-16, the same.
# Then, on GPU 0, the Fig. 6 sweep of g64's R16 (seed 11, 20 rounds, 11 points).
# Rule, fixed before anything ran (widened from "both trainings" to every training the machine
# allows, since a larger machine may be lent): 16 bins becomes the gpu preset's gate_table.bins if,
# on every training, VAGS with the 16-bin table runs below 1.35 motions per grasped object and at
# least 5 points of success above its ablation on 6-10 objects, on every seed of 11-13.
# The final run is then g64's R16; otherwise the final run stays g60 (twenty-sixth look).
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
cd $S
mkdir -p /root/runs; L=/root/runs/machine_log.txt
NG=$(nvidia-smi --query-gpu=name --format=csv,noheader | wc -l)
echo "start $(date +%T) $NG GPUs: $(nvidia-smi --query-gpu=name --format=csv,noheader | tr '\n' ' ')" > $L
for G in $(seq 0 $((NG-1))); do
  [ $G -lt 4 ] || break
  bash /root/chain.sh $G $((64+G)) $((2+G)) $([ $G = 0 ] && echo sweep) &
done
wait
echo "done $(date +%T)" >> $L
