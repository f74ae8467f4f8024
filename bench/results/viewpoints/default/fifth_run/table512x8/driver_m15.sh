#!/usr/bin/env bash
# Issue 23: the fifth run's networks with a table of 4x the states (512 piles x 8 attempts) in the
# preset's 8 bins, played on seeds 11-16; the per-state rows come back for analysis.
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1
O=runs/o15; log=runs/m15.log; mkdir -p $O runs
tar xzf /root/r12.tgz -C runs && mv runs/r12 runs/r12c
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
t0=$(date +%s); python -m vags_jax.stages.gate_measure --run runs/r12c --worlds 512 --steps 8 --bins 8 > $O/gate512x8.txt 2>$O/gate512x8.err
echo "gate rc=$? $(( $(date +%s) - t0 )) s $(date +%T)" >> $log; cp runs/r12c/gate.json $O/gate512x8.json; cp runs/r12c/gate_states.npz $O/gate512x8_states.npz
t1=$(date +%s); python eval.py --run runs/r12c --seeds 11,12,13 --cache-dir /root/cc-c --out "$O/seed{seed}/eval_vags-rate512x8.json" > $O/rate512x8.txt 2>&1
echo "eval rc=$? $(( $(date +%s) - t1 )) s $(date +%T)" >> $log
tar czf runs/o15.tgz -C runs o15; touch runs/m15_done
