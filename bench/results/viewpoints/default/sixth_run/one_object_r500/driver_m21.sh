#!/usr/bin/env bash
# Issue 23: moves at one object on the sixth run's networks, group 1 x 500 rounds, VAGS and --no-viewpoint side by side.
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1 XLA_PYTHON_CLIENT_MEM_FRACTION=0.3
unset JAX_COMPILATION_CACHE_DIR
O=runs/o21; log=runs/m21.log; mkdir -p $O
tar xzf .dev/o16/r16.tgz -C runs
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
for pol in vags vags-no-viewpoint; do
  ( flag=""; [ $pol = vags-no-viewpoint ] && flag="--no-viewpoint"
    t=$(date +%s); python eval.py --run runs/r16 $flag --groups 1 --rounds 500 --seed 21 --cache-dir /root/cc-eval --out $O/eval_$pol.json > $O/eval_$pol.txt 2>&1
    echo "$pol rc=$? $(( $(date +%s)-t )) s $(date +%T)" >> $log ) &
done
wait; touch runs/m21_done
