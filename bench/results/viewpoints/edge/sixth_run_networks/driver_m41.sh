#!/usr/bin/env bash
# Session of 2026-11-27 evening: (1) the sixth run's networks (split pick, seen) on the edge scenes,
# VAGS and ablation, seeds 11-13; (2) bench/train_throughput.py with quarter turns, then with every
# rotation resampled (the previous path), one after the other on the same machine.
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
O=$PWD/runs/o41; log=$O/machine_log.txt; mkdir -p $O; C=/root/cc
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $O/$k.txt 2>&1; echo "$k rc=$? $(( $(date +%s)-t )) s $(date +%T)" >> $log; }
ev() { f=$1; shift; XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=$f run "$@"; }
M=runs/r16m; S=runs/r16s
mkdir $S && cp -al $M/stage2 $M/stage3 $S/ && cp .dev/m36/gate_seen.json $S/gate.json && python - <<'PY'
import json
d = json.load(open("runs/r16m/config.json")); d["vags"]["close_region"] = "seen"
json.dump(d, open("runs/r16s/config.json", "w"), indent=1)
PY
ev 0.45 edge_vags python eval.py --run $S --scenes edge --seeds 11,12,13 --cache-dir $C --out "$O/edge/seed{seed}/eval_vags.json" &
ev 0.45 edge_nv python eval.py --run $S --scenes edge --no-viewpoint --seeds 11,12,13 --cache-dir $C --out "$O/edge/seed{seed}/eval_vags-no-viewpoint.json" &
wait
run tp_quarter python bench/train_throughput.py --config gpu --cache-dir $C --out $O/throughput/stage1_gpu_quarter_turns_h100.json
cp vags_jax/nets/qnet.py /tmp/qnet_keep.py
sed -i 's/^    if n_rotations % 4 or padded.shape\[1\] != padded.shape\[2\]:$/    if True:  # every rotation resampled/' vags_jax/nets/qnet.py
if grep -q "if True:  # every rotation resampled" vags_jax/nets/qnet.py; then
  run tp_resampled python bench/train_throughput.py --config gpu --trunks small --cache-dir $C --out $O/throughput/stage1_gpu_resampled_h100.json
else echo "sed did not apply" >> $log; fi
cp /tmp/qnet_keep.py vags_jax/nets/qnet.py
echo "done $(date +%T)" >> $log
