#!/usr/bin/env bash
# One GPU's chain of driver.sh: chain.sh GPU N SEED TRAIN_CLOSE_SCORE [sweep]
G=$1; N=$2; SEED=$3; TCS=$4; SWEEP=$5
export CUDA_VISIBLE_DEVICES=$G
O=/root/runs/o$N; mkdir -p $O; C=/root/cc$G; R=/root/runs/g$N; L=/root/runs/machine_log.txt
run() { k=$1; shift; t=$(date +%s); "$@" > $O/$k.txt 2>&1; rc=$?; echo "g$N $k rc=$rc $(( $(date +%s)-t )) s $(date +%T)" >> $L; return $rc; }
ev() { f=$1; shift; XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=$f run "$@"; }
run train timeout 1100 python train.py --config gpu --set seed=$SEED vags.train_close_score=$TCS --out $R --cache-dir $C --json
mkdir -p $O/run; for f in config.json timings.jsonl summary.json gate.json gate_states.npz compile_ahead.log compile_ahead_gate.log; do cp $R/$f $O/run/ 2>/dev/null; done
ev 0.3 vags_nv python eval.py --run $R --no-viewpoint --seeds 11,12,13 --cache-dir $C --out "$O/seed{seed}/eval_vags-no-viewpoint.json" &
ev 0.3 vags python eval.py --run $R --seeds 11,12,13 --cache-dir $C --out "$O/seed{seed}/eval_vags.json" &
ev 0.3 vags_cap python eval.py --run $R --set vags.max_motion_number=1.3 --seeds 11,12,13 --cache-dir $C --out "$O/cap1.3/seed{seed}/eval_vags.json" &
wait
echo "g$N evals done $(date +%T)" >> $L
if [ -n "$SWEEP" ]; then
  ev 0.9 sweep python eval.py --run $R --seed 11 --rounds 20 --threshold-sweep=-0.25:0.25:0.05 --cache-dir $C --out "$O/sweep/eval_vags_r20.json"
fi
echo "g$N chain done $(date +%T)" >> $L
