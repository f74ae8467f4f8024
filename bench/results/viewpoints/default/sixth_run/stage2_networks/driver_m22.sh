#!/usr/bin/env bash
# Issue 23: does stage 3 change GDNet's direct grasps?  The sixth run's networks after stage 2
# (r16s2: stage 3 removed) against after stage 3 (r16), side by side on seeds 11-13:
# --no-viewpoint for both; VAGS for r16s2 with a rate table measured on its own networks.
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1 XLA_PYTHON_CLIENT_MEM_FRACTION=0.3
unset JAX_COMPILATION_CACHE_DIR
O=runs/o22; log=runs/m22.log; mkdir -p $O
tar xzf .dev/o16/r16.tgz -C runs
rm -rf runs/r16s2; cp -r runs/r16 runs/r16s2; rm -rf runs/r16s2/stage3 runs/r16s2/gate.json
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $O/$k.txt 2>&1; echo "$k rc=$? $(( $(date +%s)-t )) s $(date +%T)" >> $log; }
run r16_nv python eval.py --run runs/r16 --no-viewpoint --seeds 11,12,13 --cache-dir /root/cc-a --out "$O/r16/seed{seed}/eval_vags-no-viewpoint.json" &
run r16s2_nv python eval.py --run runs/r16s2 --no-viewpoint --seeds 11,12,13 --cache-dir /root/cc-b --out "$O/r16s2/seed{seed}/eval_vags-no-viewpoint.json" &
( run r16s2_gate python -m vags_jax.stages.gate_measure --run runs/r16s2
  cp runs/r16s2/gate.json runs/r16s2/gate_states.npz $O/ 2>/dev/null
  run r16s2_vags python eval.py --run runs/r16s2 --seeds 11,12,13 --cache-dir /root/cc-c --out "$O/r16s2/seed{seed}/eval_vags.json" ) &
wait; touch runs/m22_done
