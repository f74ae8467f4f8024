#!/usr/bin/env bash
# Issue 23, twenty-ninth look: the split motion cap of 1.28 on new trainings of the gpu preset
# (training seeds 10-13), through scripts/seed_runs.py, one GPU training its seeds in turn.
# Each run, seeds 11-13, groups 1-10 x 50 rounds: the ablation, VAGS uncapped, VAGS capped at 1.28.
# s10's Fig. 6 sweep under the cap runs on GPU 0 once s10's evaluations are done (alongside s12's
# training when two GPUs share four seeds).
# Rule (fixed in bench/RESULTS.md, twenty-eighth look, before anything ran): the cap becomes the
# gpu preset's default if it meets every goal on more seed evaluations than uncapped VAGS and
# runs below 1.35 motions on every one.
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
cd $S
O=/root/runs/look; mkdir -p $O; L=$O/log.txt
NG=$(nvidia-smi --query-gpu=name --format=csv,noheader | wc -l)
echo "start $(date +%T) $NG GPUs, seeds 10,11,12,13" >> $L
(while [ $(grep -c "^s10 \(ablation\|vags\|cap1.28\) rc=" $L) -lt 3 ] && ! grep -q "^first done" $L; do sleep 5; done
 mkdir -p $O/s10/sweep
 CUDA_VISIBLE_DEVICES=0 XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=0.2 \
   python eval.py --run $O/s10/run --seed 11 --rounds 20 --threshold-sweep=-0.25:0.25:0.05 \
   --set vags.max_motion_number=1.28 --cache-dir $O/cache/gpu0s --out $O/s10/sweep/eval_vags_r20.json > $O/s10/sweep.txt 2>&1
 echo "sweep rc=$? $(date +%T)" >> $L) &
python scripts/seed_runs.py --seeds 10,11,12,13 --out $O --per-gpu 3 \
  --eval ablation=--no-viewpoint --eval vags= --eval cap1.28="--set vags.max_motion_number=1.28" > $O/first.txt 2>&1
echo "first done $(date +%T) rc=$?" >> $L
wait
python scripts/seed_runs.py --summary $O > $O/summary.md 2>&1
echo "done $(date +%T)" >> $L
