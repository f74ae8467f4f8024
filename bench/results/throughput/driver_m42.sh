#!/usr/bin/env bash
# Stage-1 throughput with SmallTrunk's space-to-depth first conv, then with the plain strided conv,
# one after the other on one machine; then trunk_speed.py.
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
O=$PWD/runs/o42; log=$O/machine_log.txt; mkdir -p $O/throughput; C=/root/cc
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $O/$k.txt 2>&1; echo "$k rc=$? $(( $(date +%s)-t )) s $(date +%T)" >> $log; }
run tp_s2d python bench/train_throughput.py --config gpu --trunks small --cache-dir $C --out $O/throughput/stage1_gpu_h100_s2d.json
cp vags_jax/nets/small.py /tmp/small_keep.py
sed -i 's/^            if i == 0:$/            if False:  # the plain strided conv/' vags_jax/nets/small.py
if grep -q "if False:  # the plain strided conv" vags_jax/nets/small.py; then
  run tp_plain python bench/train_throughput.py --config gpu --trunks small --cache-dir $C --out $O/throughput/stage1_gpu_h100_plain.json
else echo "sed did not apply" >> $log; fi
cp /tmp/small_keep.py vags_jax/nets/small.py
run ts python bench/trunk_speed.py --batches 1024 --out $O/throughput/trunk_speed_h100_after.json
echo "done $(date +%T)" >> $log
