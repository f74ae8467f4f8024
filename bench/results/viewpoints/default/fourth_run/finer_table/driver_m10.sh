#!/usr/bin/env bash
# Issue 23: the rate gate's table measured with more states and finer bins (512 piles x 8 attempts, 16 bins)
# on the fourth run, then evaluated on seeds 11-13 and on fresh seeds 14-16, beside the 8-bin table and the
# ablation on seeds 14-16.
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1 XLA_PYTHON_CLIENT_PREALLOCATE=false
unset JAX_COMPILATION_CACHE_DIR
O=runs/o10; log=runs/m10.log; mkdir -p $O runs; tar xzf /root/r8.tgz -C runs; rm -rf runs/r8f; cp -r runs/r8 runs/r8f
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
ev() {  # name run seeds flags...
  local name=$1 run=$2 seeds=$3; shift 3; local t1=$(date +%s)
  python eval.py --run $run "$@" --seeds $seeds --cache-dir /root/cc-$name --out "$O/seed{seed}/eval_${name%%@*}.json" > $O/$name.txt 2>&1
  echo "$name rc=$? $(( $(date +%s) - t1 )) s $(date +%T)" >> $log
}
ev vags-rate@14 runs/r8 14,15,16 --set vags.gate=rate &
ev vags-no-viewpoint@14 runs/r8 14,15,16 --no-viewpoint &
(
  t0=$(date +%s)
  python -m vags_jax.stages.gate_measure --run runs/r8f --worlds 512 --steps 8 --bins 16 > $O/gate16.txt 2>&1
  echo "gate16 rc=$? $(( $(date +%s) - t0 )) s $(date +%T)" >> $log; cp runs/r8f/gate.json $O/gate16.json
  ev vags-rate16@11 runs/r8f 11,12,13 --set vags.gate=rate &
  ev vags-rate16@14 runs/r8f 14,15,16 --set vags.gate=rate &
  wait
) &
wait
touch runs/m10_done
