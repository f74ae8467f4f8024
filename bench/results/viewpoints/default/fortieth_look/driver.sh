#!/usr/bin/env bash
# Written on 2026-12-07, before the device call that runs it.
# Issues 23 and 27.  The benchmark now re-drops spilled piles by default (benchmark.redrop_spilled,
# null = 10 on pile scenes; thirty-ninth look).  This measures, on the new default:
# 1. One new training (gpu preset, seed 56), then VAGS and --no-viewpoint on the benchmark's own
#    defaults (no --set), groups 1-10 x 50, seeds 11-13, two processes at once.  A second training
#    under the new protocol for issue 23's goals; no default depends on it.
# 2. One 500-round VAGS table (seed 11) alone on the warm cache, timed as a whole process: issue
#    27's goal of under 40 s, measured again since re-drops run before every table now.
# 3. Both policies again with benchmark.redrop_spilled=0 (the protocol before the thirty-ninth look),
#    two at once: how the re-drops move the VAGS-ablation comparison on one run.
# On ONE bare H100 (or H200), after the wheels.  About 9 minutes.
# Poll with: bash /root/src/bench/results/throughput/forward_needed/poll.sh 560 /root/res/machine_log.txt
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1 CUDA_VISIBLE_DEVICES=0
unset JAX_COMPILATION_CACHE_DIR
cd $S
RES=/root/res C=/root/cc
source bench/driver_lib.sh
start_log

R=/root/runs/s56 O=$RES/s56
run train_s56 timeout 700 python train.py --config gpu --set seed=56 --out $R --cache-dir $C --json
keep $R $O
if [ -f $R/gate.json ]; then
  E="--seeds 11,12,13 --cache-dir $C"
  ev vags python eval.py --run $R $E --out "$O/seed{seed}/eval_vags.json" &
  ev abl python eval.py --run $R --no-viewpoint $E --out "$O/seed{seed}/eval_vags-no-viewpoint.json" &
  wait
  run vags_alone bash -c "time python eval.py --run $R --seed 11 --cache-dir $C --out $O/alone/eval_vags.json"
  E0="$E --set benchmark.redrop_spilled=0"
  ev vags_d0 python eval.py --run $R $E0 --out "$O/d0/seed{seed}/eval_vags.json" &
  ev abl_d0 python eval.py --run $R --no-viewpoint $E0 --out "$O/d0/seed{seed}/eval_vags-no-viewpoint.json" &
  wait
fi
echo "done $(date +%T)" >> $RES/machine_log.txt
