#!/usr/bin/env bash
# Issue 23: the fifth run's networks with a table that counts knocked-off objects as picks lost
# (r12b), against the fifth run's own table again (r12, a repeat), side by side.
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1
O=runs/o13; log=runs/m13.log; mkdir -p $O runs
tar xzf /root/r12.tgz -C runs && cp -r runs/r12 runs/r12b
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
export XLA_PYTHON_CLIENT_MEM_FRACTION=0.3
t0=$(date +%s); python -m vags_jax.stages.gate_measure --run runs/r12b --count-lost > $O/gate_count_lost.txt 2>$O/gate_count_lost.err
echo "gate rc=$? $(( $(date +%s) - t0 )) s $(date +%T)" >> $log; cp runs/r12b/gate.json $O/gate_count_lost.json
( t1=$(date +%s); python eval.py --run runs/r12b --seeds 11,12,13,14,15,16 --cache-dir /root/cc-b --out "$O/seed{seed}/eval_vags-rate-count-lost.json" > $O/count_lost.txt 2>&1
  echo "count-lost rc=$? $(( $(date +%s) - t1 )) s $(date +%T)" >> $log ) &
( t1=$(date +%s); python eval.py --run runs/r12 --seeds 11,12,13 --cache-dir /root/cc-a --out "$O/seed{seed}/eval_vags-rate-repeat.json" > $O/repeat.txt 2>&1
  echo "repeat rc=$? $(( $(date +%s) - t1 )) s $(date +%T)" >> $log ) &
wait; tar czf runs/o13.tgz -C runs o13; touch runs/m13_done
