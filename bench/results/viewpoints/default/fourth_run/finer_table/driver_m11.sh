#!/usr/bin/env bash
# The second half of driver_m10.sh after its out-of-memory failures: the 8-bin evaluation on seeds 14-16
# beside the 16-bin table's measurement, then both 16-bin evaluations (two processes at a time).
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1 XLA_PYTHON_CLIENT_PREALLOCATE=false
unset JAX_COMPILATION_CACHE_DIR
O=runs/o10; log=runs/m10.log
ev() {
  local name=$1 run=$2 seeds=$3; shift 3; local t1=$(date +%s)
  python eval.py --run $run "$@" --seeds $seeds --cache-dir /root/cc-$name --out "$O/seed{seed}/eval_${name%%@*}.json" > $O/$name.txt 2>&1
  echo "$name rc=$? $(( $(date +%s) - t1 )) s $(date +%T)" >> $log
}
echo "second start $(date +%T)" >> $log
ev vags-rate@14 runs/r8 14,15,16 --set vags.gate=rate &
t0=$(date +%s)
python -m vags_jax.stages.gate_measure --run runs/r8f --worlds 512 --steps 8 --bins 16 > $O/gate16.txt 2>&1
echo "gate16 rc=$? $(( $(date +%s) - t0 )) s $(date +%T)" >> $log; cp runs/r8f/gate.json $O/gate16.json
wait
ev vags-rate16@11 runs/r8f 11,12,13 --set vags.gate=rate &
ev vags-rate16@14 runs/r8f 14,15,16 --set vags.gate=rate &
wait
touch runs/m10_done
