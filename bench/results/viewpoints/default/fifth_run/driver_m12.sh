#!/usr/bin/env bash
# Issue 23, fifth run: a fresh gpu pipeline (gate table now with objects lost per branch), then
# VAGS (rate gate, the preset's) and --no-viewpoint on seeds 11-13, then 14-16, two evals side by side.
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
O=runs/o12; R=runs/r12; log=runs/m12.log; mkdir -p $O
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
t0=$(date +%s); python train.py --config gpu --out $R --cache-dir /root/cc-train --quiet --json > $O/train.txt 2>&1
echo "train rc=$? $(( $(date +%s) - t0 )) s $(date +%T)" >> $log
cp $R/config.json $R/timings.jsonl $R/summary.json $R/gate.json $O/ 2>/dev/null
cp $R/metrics.jsonl $O/metrics_stage1.jsonl; for s in 2 3; do cp $R/stage$s/metrics.jsonl $O/metrics_stage$s.jsonl 2>/dev/null; done
(cd runs && tar czf r12.tgz r12/config.json r12/gate.json r12/stage2/networks r12/stage3/networks); ls -la runs/r12.tgz >> $log
export XLA_PYTHON_CLIENT_MEM_FRACTION=0.3
for seeds in 11,12,13 14,15,16; do
  for pol in vags-rate vags-no-viewpoint; do
    (
      flag=""; [ $pol = vags-no-viewpoint ] && flag="--no-viewpoint"
      t1=$(date +%s); python eval.py --run $R $flag --seeds $seeds --cache-dir /root/cc-$pol --out "$O/seed{seed}/eval_$pol.json" > $O/${pol}_$seeds.txt 2>&1
      echo "$pol $seeds rc=$? $(( $(date +%s) - t1 )) s $(date +%T)" >> $log
    ) &
  done
  wait
  touch runs/m12_done_$seeds
done
touch runs/m12_done
