#!/usr/bin/env bash
# Session of 2026-11-28 (third): the `gpu` pipeline cold, then warm (stage checkpoints written in
# the background, 5738a30), then VAGS and its ablation on seeds 11-13 for both trainings.
# Runs from a copy of the tree, so that later calls' copies cannot change the code it runs.
S=/root/src; mkdir -p $S; tar cf - --exclude=./runs --exclude=./.dev --exclude=./bench/results . | tar xf - -C $S; cd $S
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
O=/root/runs/o53; log=$O/machine_log.txt; mkdir -p $O; C=/root/cc
echo "start $(date +%T) $(git -C /root/src log -1 --format=%h 2>/dev/null) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $O/$k.txt 2>&1; echo "$k rc=$? $(( $(date +%s)-t )) s $(date +%T)" >> $log; }
ev() { f=$1; shift; XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=$f run "$@"; }
R=/root/runs/g53; W=/root/runs/g53w
keep() { mkdir -p $O/$2; for f in config.json timings.jsonl summary.json gate.json compile_ahead.log; do cp $1/$f $O/$2/ 2>/dev/null; done; }
run train python train.py --config gpu --out $R --cache-dir $C --json
keep $R cold
run train_warm python train.py --config gpu --out $W --cache-dir $C --json
keep $W warm
ev 0.45 vags python eval.py --run $R --seeds 11,12,13 --cache-dir $C --out "$O/cold/seed{seed}/eval_vags.json" &
ev 0.45 vags_nv python eval.py --run $R --no-viewpoint --seeds 11,12,13 --cache-dir $C --out "$O/cold/seed{seed}/eval_vags-no-viewpoint.json" &
wait
echo "evals $(date +%T)" >> $log
ev 0.45 wvags python eval.py --run $W --seeds 11,12,13 --cache-dir $C --out "$O/warm/seed{seed}/eval_vags.json" &
ev 0.45 wvags_nv python eval.py --run $W --no-viewpoint --seeds 11,12,13 --cache-dir $C --out "$O/warm/seed{seed}/eval_vags-no-viewpoint.json" &
wait
echo "done $(date +%T)" >> $log
