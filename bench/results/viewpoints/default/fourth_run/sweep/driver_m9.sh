#!/usr/bin/env bash
# Issue 23: the Fig. 6 sweep on the fourth run (runs/r8), 11 quantiles x groups 1-10 x 20 rounds, seed 11,
# for the success gate (the run's own) and the rate gate, side by side.
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1 XLA_PYTHON_CLIENT_MEM_FRACTION=0.4
unset JAX_COMPILATION_CACHE_DIR
O=runs/o9; log=runs/m9.log; mkdir -p $O runs; tar xzf /root/r8.tgz -C runs
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
for pol in vags vags-rate; do
  (
    flag=""; [ $pol = vags-rate ] && flag="--set vags.gate=rate"
    t1=$(date +%s); python eval.py --run runs/r8 $flag --rounds 20 --seed 11 --quantile-sweep 0:1:0.1 --cache-dir /root/cc-$pol --out "$O/eval_${pol}_r20.json" > $O/$pol.txt 2>&1
    echo "sweep $pol rc=$? $(( $(date +%s) - t1 )) s $(date +%T)" >> $log
  ) &
done
wait
touch runs/m9_done
