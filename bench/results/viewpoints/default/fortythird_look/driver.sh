#!/usr/bin/env bash
# Written on 2026-12-08 during the device lease, right after the forty-second look on the same
# warm H100 (its /root/runs/s57 and compile cache are still there).  Issues 27 and 23.
#  1. Issue 27: two more 500-round VAGS tables (seed 11) on s57 alone on the warm cache, each timed
#     as a whole process, to show the spread of the forty-second look's one (33.3 s).
#  2. Issue 23: one more training of the gpu preset as it is, s58 (seed 58, never trained), and its
#     benchmark (groups 1-10 x 50, seeds 11-13), VAGS and --no-viewpoint at once.  No decision
#     hangs on it: it adds three seed evaluations to the per-seed and pooled record of the preset.
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1 CUDA_VISIBLE_DEVICES=0
unset JAX_COMPILATION_CACHE_DIR
cd $S
RES=/root/res/fortythird C=/root/cc
source bench/driver_lib.sh
start_log
for k in 2 3; do
  run vags_alone_$k bash -c "time python eval.py --run /root/runs/s57 --seed 11 --cache-dir $C --out $RES/alone$k/eval_vags.json"
done
R=/root/runs/s58 O=$RES/s58
run train_s58 timeout 800 python train.py --config gpu --set seed=58 --out $R --cache-dir $C --json
keep $R $O
if [ -f $R/gate.json ]; then
  E="--seeds 11,12,13 --cache-dir $C"
  ev vags python eval.py --run $R $E --out "$O/seed{seed}/eval_vags.json" &
  ev abl python eval.py --run $R --no-viewpoint $E --out "$O/seed{seed}/eval_vags-no-viewpoint.json" &
  wait
fi
echo "done $(date +%T)" >> $RES/machine_log.txt
