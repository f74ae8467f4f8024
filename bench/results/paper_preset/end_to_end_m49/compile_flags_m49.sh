#!/bin/bash
# Paper preset's GDNet update compile: LLVM module parallelism vs default, one after the other.
set -u
mkdir -p $OUT/cf
nproc > $OUT/cf/nproc.txt
for v in parallel default; do
  if [ $v = parallel ]; then export XLA_FLAGS=--xla_gpu_enable_llvm_module_compilation_parallelism=true; else unset XLA_FLAGS; fi
  date -u +%T > $OUT/cf/$v.start
  /usr/bin/time -v timeout 280 python bench/compile_time.py --config paper --programs update --out $OUT/cf/update_$v.json > $OUT/cf/$v.log 2>&1
  date -u +%T > $OUT/cf/$v.end
done
nvidia-smi --query-gpu=name --format=csv > $OUT/cf/gpu.txt
