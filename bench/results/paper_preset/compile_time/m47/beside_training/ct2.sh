#!/usr/bin/env bash
# Beside the training (same machine, same time): three compile-time variants side by side.
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
O=$PWD/runs/o47; log=$O/ct2_log.txt
run() { k=$1; shift; t=$(date +%s); "$@" > $O/$k.txt 2>&1; echo "$k rc=$? $(( $(date +%s)-t )) s $(date +%T)" >> $log; }
export XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=0.06
echo "start $(date +%T)" > $log
run ct2_default python bench/compile_time.py --config paper --programs update --out $O/compile_time/beside_training/update_default.json &
XLA_FLAGS=--xla_gpu_autotune_level=1 run ct2_autotune1 python bench/compile_time.py --config paper --programs update --out $O/compile_time/beside_training/update_autotune1.json &
XLA_FLAGS=--xla_gpu_enable_triton_gemm=false run ct2_notriton python bench/compile_time.py --config paper --programs update --out $O/compile_time/beside_training/update_no_triton_gemm.json &
wait
echo "done $(date +%T)" >> $log
