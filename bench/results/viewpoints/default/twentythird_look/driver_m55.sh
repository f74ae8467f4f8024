#!/usr/bin/env bash
# After driver_m54 (whose compile-ahead threads crashed on the GPU): the reverted tree (compile
# ahead in a second process again), the `gpu` pipeline with the compile cache the fallback run
# filled, then VAGS and its ablation on seeds 11-13.
while ! grep -q "^done" /root/runs/o54/machine_log.txt; do sleep 2; done
S=/root/src2; mkdir -p $S; tar cf - -C /root/tree55 --exclude=./runs --exclude=./.dev --exclude=./bench/results . | tar xf - -C $S; cd $S
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
O=/root/runs/o55; log=$O/machine_log.txt; mkdir -p $O; C=/root/cc
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $O/$k.txt 2>&1; rc=$?; echo "$k rc=$rc $(( $(date +%s)-t )) s $(date +%T)" >> $log; return $rc; }
ev() { f=$1; shift; XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=$f run "$@"; }
W=/root/runs/g55w
keep() { mkdir -p $O/$2; for f in config.json timings.jsonl summary.json gate.json compile_ahead.log compile_ahead_gate.log; do cp $1/$f $O/$2/ 2>/dev/null; done; }
run train_warm timeout 700 python train.py --config gpu --out $W --cache-dir $C --json
keep $W warm
ev 0.45 wvags python eval.py --run $W --seeds 11,12,13 --cache-dir $C --out "$O/warm/seed{seed}/eval_vags.json" &
ev 0.45 wvags_nv python eval.py --run $W --no-viewpoint --seeds 11,12,13 --cache-dir $C --out "$O/warm/seed{seed}/eval_vags-no-viewpoint.json" &
wait
echo "done $(date +%T)" >> $log
