#!/usr/bin/env bash
# Session of 2026-11-28: the `gpu` pipeline (default scenes) from a bare machine, stages 2 and 3
# sharing one program (timings.jsonl); its VAGS and ablation tables (seeds 11-13); a warm
# 500-round table (seed 14); then the same pipeline again with the warm cache.
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
O=$PWD/runs/o51; log=$O/machine_log.txt; mkdir -p $O; C=/root/cc
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $O/$k.txt 2>&1; echo "$k rc=$? $(( $(date +%s)-t )) s $(date +%T)" >> $log; }
ev() { f=$1; shift; XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=$f run "$@"; }
R=runs/g51
run train python train.py --config gpu --out $R --cache-dir $C --json
mkdir -p $O/cold; for f in config.json timings.jsonl summary.json gate.json metrics.jsonl; do cp $R/$f $O/cold/ 2>/dev/null; done
ev 0.45 vags python eval.py --run $R --seeds 11,12,13 --cache-dir $C --out "$O/seed{seed}/eval_vags.json" &
ev 0.45 vags_nv python eval.py --run $R --no-viewpoint --seeds 11,12,13 --cache-dir $C --out "$O/seed{seed}/eval_vags-no-viewpoint.json" &
wait
echo "evals $(date +%T)" >> $log
run warm_eval python eval.py --run $R --seed 14 --cache-dir $C --out $O/warm_eval/eval_vags_seed14.json
echo "warm_eval_done $(date +%T)" >> $log
run train_warm python train.py --config gpu --out runs/g51w --cache-dir $C --json
mkdir -p $O/warm; for f in timings.jsonl summary.json gate.json; do cp runs/g51w/$f $O/warm/ 2>/dev/null; done
echo "done $(date +%T)" >> $log
