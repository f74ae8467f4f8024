#!/usr/bin/env bash
# Issue 23, sixth run: a fresh gpu pipeline that measures the 512 x 8 gate table itself, then
# VAGS and --no-viewpoint on seeds 11-16 and the Fig. 6 sweep (seed 11, 20 rounds), side by side.
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
O=runs/o16; R=runs/r16; log=runs/m16.log; mkdir -p $O
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
t0=$(date +%s); python train.py --config gpu --out $R --cache-dir /root/cc-train --quiet --json > $O/train.txt 2>&1
echo "train rc=$? $(( $(date +%s) - t0 )) s $(date +%T)" >> $log
cp $R/config.json $R/timings.jsonl $R/summary.json $R/gate.json $R/gate_states.npz $O/ 2>/dev/null
cp $R/metrics.jsonl $O/metrics_stage1.jsonl; for s in 2 3; do cp $R/stage$s/metrics.jsonl $O/metrics_stage$s.jsonl 2>/dev/null; done
(cd runs && tar czf r16.tgz r16/config.json r16/gate.json r16/stage2/networks r16/stage3/networks); ls -la runs/r16.tgz >> $log
touch runs/m16_trained
export XLA_PYTHON_CLIENT_MEM_FRACTION=0.3
for pol in vags vags-no-viewpoint; do
  (
    flag=""; [ $pol = vags-no-viewpoint ] && flag="--no-viewpoint"
    t1=$(date +%s); python eval.py --run $R $flag --seeds 11,12,13,14,15,16 --cache-dir /root/cc-$pol --out "$O/seed{seed}/eval_$pol.json" > $O/eval_$pol.txt 2>&1
    echo "$pol rc=$? $(( $(date +%s) - t1 )) s $(date +%T)" >> $log
  ) &
done
(
  t1=$(date +%s); python eval.py --run $R --seed 11 --rounds 20 --threshold-sweep=-0.25:0.25:0.05 --cache-dir /root/cc-sweep --out $O/sweep/eval_vags_r20.json > $O/sweep.txt 2>&1
  echo "sweep rc=$? $(( $(date +%s) - t1 )) s $(date +%T)" >> $log
) &
wait
touch runs/m16_done
