#!/usr/bin/env bash
# Session of 2026-11-27 late, machine 1. (1) Compile time of the paper preset's DenseNet-121
# GDNet update with XLA's autotuning on and off, side by side (two processes, 0.45 of the GPU
# each). (2) A run trained on the edge variant with the close view 0.15 m above the chosen cell
# instead of 0.25 m (camera.viewpoint_height), its VAGS and ablation tables (seeds 11-13) and its
# same-states table of 6-10 objects (how much of the pile each close view sees; VANet vs random).
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
O=$PWD/runs/o47; log=$O/machine_log.txt; mkdir -p $O; C=/root/cc
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $O/$k.txt 2>&1; echo "$k rc=$? $(( $(date +%s)-t )) s $(date +%T)" >> $log; }
ev() { f=$1; shift; XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=$f run "$@"; }
ev 0.45 ct_default python bench/compile_time.py --config paper --programs update --out $O/compile_time/update_default.json &
XLA_FLAGS=--xla_gpu_autotune_level=0 ev 0.45 ct_autotune0 python bench/compile_time.py --config paper --programs update --out $O/compile_time/update_autotune0.json &
wait
R=runs/v47
run train python train.py --config gpu-edge --set camera.viewpoint_height=0.15 --out $R --cache-dir $C --json
cp $R/config.json $R/timings.jsonl $R/summary.json $R/gate.json $O/ 2>/dev/null
ev 0.45 vags python eval.py --run $R --scenes edge --seeds 11,12,13 --cache-dir $C --out "$O/seed{seed}/eval_vags.json" &
ev 0.45 vags_nv python eval.py --run $R --scenes edge --no-viewpoint --seeds 11,12,13 --cache-dir $C --out "$O/seed{seed}/eval_vags-no-viewpoint.json" &
wait
run states python bench/viewpoint_states.py --run $R --scenes edge --objects 6-10 --worlds 512 --steps 3 --cache-dir $C --out $O/states_6-10.json --rows $O/states_6-10.npz
run states_h25 python bench/viewpoint_states.py --run $R --scenes edge --set camera.viewpoint_height=0.25 --objects 6-10 --worlds 512 --steps 3 --cache-dir $C --out $O/states_6-10_h25.json --rows $O/states_6-10_h25.npz
echo "done $(date +%T)" >> $log
