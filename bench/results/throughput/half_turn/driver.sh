#!/usr/bin/env bash
# Written on 2026-12-07 before any device call of its session.
# Issue 27: GDNet over 8 rotations spanning half a turn (grasp.half_turn, new) instead of 16
# spanning a whole one.  The 8 half-turn rotations are the 8 distinct grasps of the 16 (the same
# angles r * pi / 8); the actor's pass and the target network's pass run half the rotated images.
# 1. Stage 1's rate, side by side on this one GPU (bench/train_throughput.py, the `gpu` preset):
#    the preset's target network, full turn then half turn; stage1.bootstrap=actor_argmax, full
#    turn then half turn.
# 2. Learning per attempt, one pair: h47 is f47's pipeline (the thirty-fourth look: seed 47, the
#    preset) with the half turn as the only change; then its VAGS and ablation benchmark,
#    groups 1-10 x 50 rounds, seeds 11-13, against f47's committed reports.
# 3. If time is left: hd47, h47 with stage1.bootstrap=actor_argmax, and its benchmark.
# Fixed before the run: no default changes on one pair; the figures are reported whatever they are.
# On ONE bare H100 (or H200), after the wheels.
# Poll with: bash /root/src/bench/results/throughput/forward_needed/poll.sh 560 /root/res/machine_log.txt
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1 CUDA_VISIBLE_DEVICES=0
unset JAX_COMPILATION_CACHE_DIR
cd $S
RES=/root/res; mkdir -p $RES; log=$RES/machine_log.txt
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader | tr '\n' ' ')" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $RES/$k.txt 2>&1; rc=$?; echo "$k rc=$rc $(( $(date +%s)-t )) s $(date +%T)" >> $log; return $rc; }
keep() { mkdir -p $2; for f in config.json metrics.jsonl timings.jsonl summary.json gate.json gate_states.npz; do cp $1/$f $2/ 2>/dev/null; done
         for s in stage2 stage3; do [ -f $1/$s/metrics.jsonl ] && cp $1/$s/metrics.jsonl $2/${s}_metrics.jsonl; done; }
C=/root/cc
HALF="grasp.n_rotations=8 net.n_rotations=8 grasp.half_turn=true net.half_turn=true"
TT="python bench/train_throughput.py --config gpu --trunks small --no-parts --cache-dir $C"
ev() { XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=0.3 run "$@"; }
E="--seeds 11,12,13 --cache-dir $C"
run tt_preset_full timeout 240 $TT --out $RES/tt_preset_full.json
run tt_preset_half timeout 240 $TT --set $HALF --out $RES/tt_preset_half.json
run tt_argmax_full timeout 240 $TT --set stage1.bootstrap=actor_argmax --out $RES/tt_argmax_full.json
run tt_argmax_half timeout 240 $TT --set stage1.bootstrap=actor_argmax $HALF --out $RES/tt_argmax_half.json
echo "throughput done $(date +%T)" >> $log
R=/root/runs/h47; O=$RES/h47
run train_h47 timeout 700 python train.py --config gpu --set seed=47 $HALF --out $R --cache-dir $C --json
keep $R $O
if [ -f $R/summary.json ]; then
  ev vags_h47 python eval.py --run $R $E --out "$O/seed{seed}/eval_vags.json" &
  ev abl_h47 python eval.py --run $R --no-viewpoint $E --out "$O/seed{seed}/eval_vags-no-viewpoint.json" &
  wait
fi
echo "h47 done $(date +%T)" >> $log
R=/root/runs/hd47; O=$RES/hd47
run train_hd47 timeout 600 python train.py --config gpu --set seed=47 stage1.bootstrap=actor_argmax $HALF --out $R --cache-dir $C --json
keep $R $O
if [ -f $R/summary.json ]; then
  ev vags_hd47 python eval.py --run $R $E --out "$O/seed{seed}/eval_vags.json" &
  ev abl_hd47 python eval.py --run $R --no-viewpoint $E --out "$O/seed{seed}/eval_vags-no-viewpoint.json" &
  wait
fi
echo "done $(date +%T)" >> $log
