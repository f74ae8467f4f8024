#!/usr/bin/env bash
# Written on 2026-12-07 before any device call of its session.
# Issue 23, two questions on today's `gpu` preset:
# 1. On the same states, is the gain after a move the move's or its planner's?  A fresh pipeline
#    f47 (seed 47, from an empty compile cache), then bench/gate_headroom.py on its gate table's
#    states with every diagnostic branch: direct (GDNet's argmax), moved (VANet's viewpoint, the
#    success net's argmax on the fused maps), random (a random object cell), oracle (GDNet on
#    ground-truth maps) and planned (no move: the success net's argmax on the global view).
# 2. The thirtieth look's benchmark comparison, last made on an older preset: f47's VAGS, its
#    ablation (GDNet's direct grasp) and the ablation with the success net's direct grasp
#    (`--no-viewpoint --set vags.direct_score=success`), groups 1-10 x 50 rounds, seeds 11-13.
# Issue 27, one pair: d47 is f47's pipeline (the same seed, programs from f47's cache) with
#    stage1.bootstrap=actor_argmax (new: the update's target reads the target network at the
#    action the actor chose greedily on the next state, one rotation's pass instead of sixteen),
#    then its VAGS and ablation benchmark as f47's.
# Fixed before the run:
# * f41 stays issue 23's final run: f47 is a replicate, reported beside it, whatever its figures.
# * No default changes on this run: it measures, it does not select.  The d47/f47 pair is one
#   observation of the new bootstrap's speed (stage 1's wall clock less its compiling) and of its
#   learning (stage 1's success by attempts, the benchmark), reported whatever its figures.
# On ONE bare H100 (or H200), after the wheels.
# Poll with: bash /root/src/bench/results/throughput/forward_needed/poll.sh 560 /root/res/machine_log.txt
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1 CUDA_VISIBLE_DEVICES=0
unset JAX_COMPILATION_CACHE_DIR
cd $S
RES=/root/res; mkdir -p $RES; log=$RES/machine_log.txt
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader | tr '\n' ' ')" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $RES/$k.txt 2>&1; rc=$?; echo "$k rc=$rc $(( $(date +%s)-t )) s $(date +%T)" >> $log; return $rc; }
keep() { mkdir -p $2; for f in config.json metrics.jsonl timings.jsonl summary.json gate.json gate_states.npz compile_ahead.log compile_ahead_gate.log; do cp $1/$f $2/ 2>/dev/null; done
         for s in stage2 stage3; do [ -f $1/$s/metrics.jsonl ] && cp $1/$s/metrics.jsonl $2/${s}_metrics.jsonl; done; }
C=/root/cc
ev() { XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=0.3 run "$@"; }
E="--seeds 11,12,13 --cache-dir $C"
R=/root/runs/f47; O=$RES/f47; D=/root/runs/d47; OD=$RES/d47
# Order: what the issues need most first, as the session's device time may run out.
run train_f47 timeout 700 python train.py --config gpu --set seed=47 --out $R --cache-dir $C --json
keep $R $O
[ -f $R/summary.json ] && run headroom_f47 python bench/gate_headroom.py --run $R --cache-dir $C --out $O/headroom.json --rows $O/headroom_rows.npz
run train_d47 timeout 600 python train.py --config gpu --set seed=47 stage1.bootstrap=actor_argmax --out $D --cache-dir $C --json
keep $D $OD
echo "trained $(date +%T)" >> $log
for r in f47 d47; do  # two at once, as the thirty-third look ran them
  [ -f /root/runs/$r/summary.json ] || continue
  ev vags_$r python eval.py --run /root/runs/$r $E --out "$RES/$r/seed{seed}/eval_vags.json" &
  ev abl_$r python eval.py --run /root/runs/$r --no-viewpoint $E --out "$RES/$r/seed{seed}/eval_vags-no-viewpoint.json" &
  wait
done
echo "evals done $(date +%T)" >> $log
[ -f $R/summary.json ] && ev abls_f47 python eval.py --run $R --no-viewpoint --set vags.direct_score=success $E --out "$O/success/seed{seed}/eval_vags-no-viewpoint.json"
echo "done $(date +%T)" >> $log
