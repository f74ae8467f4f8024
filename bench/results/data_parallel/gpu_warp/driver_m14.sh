#!/usr/bin/env bash
# Issue 27: stage 1 of the gpu preset (MJX impl warp) data-parallel on 2 GPUs, then on 1 GPU, 40
# iterations each, on the same host; parallel/mesh.py's GPU refusal is patched out on this copy only.
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1
O=runs/o14; log=runs/m14.log; mkdir -p $O
sed -i 's/    if platform == "gpu" and n > 1:/    if False:/' vags_jax/parallel/mesh.py
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader | tr '\n' ' ')" > $log
for n in 2 1; do
  t0=$(date +%s); timeout 400 python train.py --config gpu --stage gdnet --devices $n --set stage1.iterations=40 \
    --out runs/dp$n --cache-dir /root/cc$n --json > $O/train_devices$n.txt 2>&1
  echo "devices=$n rc=$? $(( $(date +%s) - t0 )) s $(date +%T)" >> $log
  cp runs/dp$n/metrics.jsonl $O/metrics_devices$n.jsonl 2>/dev/null; cp runs/dp$n/timings.jsonl $O/timings_devices$n.jsonl 2>/dev/null
done
tar czf runs/o14.tgz -C runs o14; touch runs/m14_done
