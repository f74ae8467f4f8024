#!/usr/bin/env bash
# Session of 2026-11-28 (fourth): the `gpu` pipeline cold, then warm, with stage 2's and the gate
# table's programs compiled ahead in threads of train.py (no second process); then VAGS and its
# ablation on seeds 11-13 for both trainings, and the Fig. 6 sweep on the cold training.
# Runs from a copy of the tree, so that later calls' copies cannot change the code it runs.
S=/root/src; mkdir -p $S; tar cf - --exclude=./runs --exclude=./.dev --exclude=./bench/results . | tar xf - -C $S; cd $S
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
O=/root/runs/o54; log=$O/machine_log.txt; mkdir -p $O; C=/root/cc
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $O/$k.txt 2>&1; rc=$?; echo "$k rc=$rc $(( $(date +%s)-t )) s $(date +%T)" >> $log; return $rc; }
ev() { f=$1; shift; XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=$f run "$@"; }
R=/root/runs/g54; W=/root/runs/g54w
keep() { mkdir -p $O/$2; for f in config.json timings.jsonl summary.json gate.json; do cp $1/$f $O/$2/ 2>/dev/null; done; }
if ! run train timeout 900 python train.py --config gpu --out $R --cache-dir $C --json; then
  # Fallback so that the session still trains: the same pipeline without compiling ahead.
  R=/root/runs/g54f; run train_fallback timeout 900 python train.py --config gpu --out $R --cache-dir $C --json --compile-ahead off
fi
keep $R cold
run train_warm timeout 900 python train.py --config gpu --out $W --cache-dir $C --json
keep $W warm
ev 0.45 vags python eval.py --run $R --seeds 11,12,13 --cache-dir $C --out "$O/cold/seed{seed}/eval_vags.json" &
ev 0.45 vags_nv python eval.py --run $R --no-viewpoint --seeds 11,12,13 --cache-dir $C --out "$O/cold/seed{seed}/eval_vags-no-viewpoint.json" &
wait
echo "evals $(date +%T)" >> $log
ev 0.45 wvags python eval.py --run $W --seeds 11,12,13 --cache-dir $C --out "$O/warm/seed{seed}/eval_vags.json" &
ev 0.45 wvags_nv python eval.py --run $W --no-viewpoint --seeds 11,12,13 --cache-dir $C --out "$O/warm/seed{seed}/eval_vags-no-viewpoint.json" &
wait
echo "evals2 $(date +%T)" >> $log
run sweep python eval.py --run $R --seed 11 --rounds 20 --threshold-sweep=-0.25:0.25:0.05 --cache-dir $C --out "$O/sweep/eval_vags_r20.json"
echo "done $(date +%T)" >> $log
