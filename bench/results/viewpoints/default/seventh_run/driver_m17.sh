#!/usr/bin/env bash
# Issues 27 and 23: the gpu pipeline from a cold cache (r17), then again with the cache warm (r18),
# then VAGS and --no-viewpoint of r17 on seeds 11-13 side by side, then one warm eval of VAGS alone.
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
O=runs/o17; log=runs/m17.log; mkdir -p $O/r17 $O/r18
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
for r in r17 r18; do
  t0=$(date +%s); python train.py --config gpu --out runs/$r --cache-dir /root/cc-train --quiet --json > $O/$r/train.txt 2>&1
  echo "train $r rc=$? $(( $(date +%s) - t0 )) s $(date +%T)" >> $log
  cp runs/$r/config.json runs/$r/timings.jsonl runs/$r/summary.json runs/$r/gate.json $O/$r/ 2>/dev/null
  cp runs/$r/metrics.jsonl $O/$r/metrics_stage1.jsonl; for s in 2 3; do cp runs/$r/stage$s/metrics.jsonl $O/$r/metrics_stage$s.jsonl 2>/dev/null; done
  touch runs/m17_trained_$r
done
export XLA_PYTHON_CLIENT_MEM_FRACTION=0.3
for pol in vags vags-no-viewpoint; do
  (
    flag=""; [ $pol = vags-no-viewpoint ] && flag="--no-viewpoint"
    t1=$(date +%s); python eval.py --run runs/r17 $flag --seeds 11,12,13 --cache-dir /root/cc-eval --out "$O/r17/seed{seed}/eval_$pol.json" > $O/r17/eval_$pol.txt 2>&1
    echo "r17 $pol rc=$? $(( $(date +%s) - t1 )) s $(date +%T)" >> $log
  ) &
done
wait; touch runs/m17_evals
unset XLA_PYTHON_CLIENT_MEM_FRACTION
t1=$(date +%s); python eval.py --run runs/r17 --seed 14 --cache-dir /root/cc-eval --out $O/r17/warm_eval/eval_vags.json > $O/r17/warm_eval.txt 2>&1
echo "r17 warm eval seed 14 rc=$? $(( $(date +%s) - t1 )) s $(date +%T)" >> $log
touch runs/m17_done
