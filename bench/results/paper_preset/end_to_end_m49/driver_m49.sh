#!/usr/bin/env bash
# Session of 2026-11-27/28 night: the paper preset end to end, its stage-2/3 chunk program
# compiled by vags_jax.stages.precompile beside stage 1's training; then its VAGS table.
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
O=$PWD/runs/o49; log=$O/machine_log.txt; mkdir -p $O; C=/root/cc
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $O/$k.txt 2>&1; echo "$k rc=$? $(( $(date +%s)-t )) s $(date +%T)" >> $log; }
R=runs/p49; S="gate_table.worlds=0"
( export XLA_PYTHON_CLIENT_MEM_FRACTION=0.45; run stage1 python train.py --config paper --set $S --stage stage1 --out $R --cache-dir $C --json ) &
P1=$!
( export XLA_PYTHON_CLIENT_MEM_FRACTION=0.35; run precompile python -m vags_jax.stages.precompile --config paper --set $S --stages stage2 --cache-dir $C --json ) &
P2=$!
( while sleep 20; do nvidia-smi --query-gpu=memory.used,utilization.gpu --format=csv,noheader >> $O/gpu_mem.txt; done ) &
MON=$!
wait $P1 $P2
run stage2 python train.py --out $R --stage stage2 --cache-dir $C --json
run stage3 python train.py --out $R --stage stage3 --cache-dir $C --json
kill $MON
for f in config.json timings.jsonl summary.json metrics.jsonl; do cp $R/$f $O/ 2>/dev/null; done
for s in stage2 stage3; do cp $R/$s/metrics.jsonl $O/${s}_metrics.jsonl 2>/dev/null; done
run eval_vags python eval.py --run $R --seed 11 --cache-dir $C --out $O/seed11/eval_vags.json
run eval_nv python eval.py --run $R --no-viewpoint --seed 11 --cache-dir $C --out $O/seed11/eval_vags-no-viewpoint.json
echo "done $(date +%T)" >> $log
