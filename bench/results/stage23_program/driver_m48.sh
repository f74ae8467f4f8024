#!/usr/bin/env bash
# Session of 2026-11-27 late, machine 2: stages 2 and 3 sharing one compiled program on the GPU
# (gpu preset, short stages): stage 3 compiles nothing, and the 16 GB replays still fit.
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
O=$PWD/runs/o48; log=$O/machine_log.txt; mkdir -p $O; C=/root/cc
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $O/$k.txt 2>&1; echo "$k rc=$? $(( $(date +%s)-t )) s $(date +%T)" >> $log; }
R=runs/s48
run train python train.py --config gpu --out $R --cache-dir $C --json --set stage1.iterations=24 stage2.iterations=16 stage3.iterations=16 gate_table.worlds=64 gate_table.steps=2
cp $R/config.json $R/timings.jsonl $R/summary.json $O/ 2>/dev/null
nvidia-smi --query-gpu=memory.used,memory.total --format=csv >> $log
echo "done $(date +%T)" >> $log
