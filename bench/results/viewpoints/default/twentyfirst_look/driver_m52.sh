#!/usr/bin/env bash
# Session of 2026-11-28 (second): the `gpu` pipeline cold with --compile-ahead (auto: on), its VAGS
# and ablation tables (seeds 11-13), VAGS with the motion cap 1.3 on its 8-bin table and on the
# same table refit over 16 bins, then the pipeline again with the warm cache.
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
O=$PWD/runs/o52; log=$O/machine_log.txt; mkdir -p $O; C=/root/cc
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $O/$k.txt 2>&1; echo "$k rc=$? $(( $(date +%s)-t )) s $(date +%T)" >> $log; }
ev() { f=$1; shift; XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=$f run "$@"; }
R=runs/g52
run train python train.py --config gpu --out $R --cache-dir $C --json
mkdir -p $O/cold; for f in config.json timings.jsonl summary.json gate.json metrics.jsonl compile_ahead.log; do cp $R/$f $O/cold/ 2>/dev/null; done
# The same table over 16 bins (no simulation), in a run that links everything else to R's.
python -m vags_jax.stages.gate_measure --run $R --refit --bins 16 --out $O/r16 > $O/refit16.txt 2>&1
mkdir -p runs/g52r16; for f in $R/*; do ln -s $(realpath $f) runs/g52r16/; done
rm runs/g52r16/gate.json runs/g52r16/gate_states.npz; cp $O/r16/gate.json $O/r16/gate_states.npz runs/g52r16/
echo "refit $(date +%T)" >> $log
ev 0.45 vags python eval.py --run $R --seeds 11,12,13 --cache-dir $C --out "$O/seed{seed}/eval_vags.json" &
ev 0.45 vags_nv python eval.py --run $R --no-viewpoint --seeds 11,12,13 --cache-dir $C --out "$O/seed{seed}/eval_vags-no-viewpoint.json" &
wait
echo "evals $(date +%T)" >> $log
ev 0.45 cap python eval.py --run $R --set vags.max_motion_number=1.3 --seeds 11,12,13 --cache-dir $C --out "$O/cap130/seed{seed}/eval_vags.json" &
ev 0.45 cap16 python eval.py --run runs/g52r16 --set vags.max_motion_number=1.3 --seeds 11,12,13 --cache-dir $C --out "$O/bins16_cap130/seed{seed}/eval_vags.json" &
wait
echo "caps $(date +%T)" >> $log
run train_warm python train.py --config gpu --out runs/g52w --cache-dir $C --json
mkdir -p $O/warm; for f in timings.jsonl summary.json gate.json compile_ahead.log; do cp runs/g52w/$f $O/warm/ 2>/dev/null; done
echo "done $(date +%T)" >> $log
