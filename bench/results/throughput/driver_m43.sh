#!/usr/bin/env bash
# Stage-1 throughput with SmallTrunk as committed (BatchNorm folded in eval mode), then with BatchNorm not folded,
# one after the other on one machine; then trunk_speed.py.
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
O=$PWD/runs/o43; log=$O/machine_log.txt; mkdir -p $O/throughput; C=/root/cc
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $O/$k.txt 2>&1; echo "$k rc=$? $(( $(date +%s)-t )) s $(date +%T)" >> $log; }
run tp_folded python bench/train_throughput.py --config gpu --trunks small --cache-dir $C --out $O/throughput/stage1_gpu_h100_folded.json
cp vags_jax/nets/small.py /tmp/small_keep43.py
sed -i 's/^            if train or self.is_initializing():$/            if True:  # BatchNorm not folded/' vags_jax/nets/small.py
if grep -q "if True:  # BatchNorm not folded" vags_jax/nets/small.py; then
  run tp_s2d python bench/train_throughput.py --config gpu --trunks small --cache-dir $C --out $O/throughput/stage1_gpu_h100_s2d_only.json
else echo "sed did not apply" >> $log; fi
cp /tmp/small_keep43.py vags_jax/nets/small.py
run ts python bench/trunk_speed.py --batches 1024 --out $O/throughput/trunk_speed_h100_folded_product.json
echo "done $(date +%T)" >> $log
