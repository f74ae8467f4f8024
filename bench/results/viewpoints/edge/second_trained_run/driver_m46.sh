#!/usr/bin/env bash
# Session of 2026-11-27 night, machine 2: a second run trained on the edge variant (--config
# gpu-edge) from a bare machine; VAGS with its own "rate" gate and with the "success" gate, and
# its ablation, on the edge scenes (seeds 11-13; two processes at a time at 0.45 of the GPU);
# the same-states table of 6-10 objects.
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
O=$PWD/runs/o46; log=$O/machine_log.txt; mkdir -p $O; C=/root/cc
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $O/$k.txt 2>&1; echo "$k rc=$? $(( $(date +%s)-t )) s $(date +%T)" >> $log; }
ev() { f=$1; shift; XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=$f run "$@"; }
R=runs/e46
run train python train.py --config gpu-edge --out $R --cache-dir $C --json
cp $R/config.json $R/timings.jsonl $R/summary.json $R/gate.json $O/ 2>/dev/null
ev 0.45 vags_rate python eval.py --run $R --scenes edge --seeds 11,12,13 --cache-dir $C --out "$O/seed{seed}/eval_vags.json" &
ev 0.45 vags_nv python eval.py --run $R --scenes edge --no-viewpoint --seeds 11,12,13 --cache-dir $C --out "$O/seed{seed}/eval_vags-no-viewpoint.json" &
wait
ev 0.45 vags_success python eval.py --run $R --scenes edge --set vags.gate=success --seeds 11,12,13 --cache-dir $C --out "$O/seed{seed}/eval_vags-success-gate.json" &
ev 0.45 states python bench/viewpoint_states.py --run $R --scenes edge --objects 6-10 --worlds 512 --steps 3 --out $O/states_6-10.json &
wait
echo "done $(date +%T)" >> $log
