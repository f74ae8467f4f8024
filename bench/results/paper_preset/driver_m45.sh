#!/usr/bin/env bash
# Session of 2026-11-27 night, machine 1 (after driver_m44.sh): the paper preset end to end,
# then its VAGS table and its ablation's (groups 1-10 x 50 rounds, seed 11).
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
O=$PWD/runs/o45; log=$O/machine_log.txt; mkdir -p $O; C=/root/cc
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $O/$k.txt 2>&1; echo "$k rc=$? $(( $(date +%s)-t )) s $(date +%T)" >> $log; }
R=runs/p45
run train python train.py --config paper --out $R --cache-dir $C --json
for f in config.json timings.jsonl summary.json gate.json metrics.jsonl; do cp $R/$f $O/ 2>/dev/null; done
for s in stage2 stage3; do cp $R/$s/metrics.jsonl $O/${s}_metrics.jsonl 2>/dev/null; done
run eval_vags python eval.py --run $R --seed 11 --cache-dir $C --out $O/seed11/eval_vags.json
run eval_nv python eval.py --run $R --no-viewpoint --seed 11 --cache-dir $C --out $O/seed11/eval_vags-no-viewpoint.json
echo "done $(date +%T)" >> $log
