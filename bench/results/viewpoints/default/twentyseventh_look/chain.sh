#!/usr/bin/env bash
# One GPU's chain of driver.sh: chain.sh GPU N SEED [sweep]
G=$1; N=$2; SEED=$3; SWEEP=$4
export CUDA_VISIBLE_DEVICES=$G
O=/root/runs/o$N; mkdir -p $O; C=/root/cc$G; R=/root/runs/g$N; R16=/root/runs/g${N}_16; L=/root/runs/machine_log.txt
run() { k=$1; shift; t=$(date +%s); "$@" > $O/$k.txt 2>&1; rc=$?; echo "g$N $k rc=$rc $(( $(date +%s)-t )) s $(date +%T)" >> $L; return $rc; }
ev() { f=$1; shift; XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=$f run "$@"; }
run train timeout 1100 python train.py --config gpu --set seed=$SEED --out $R --cache-dir $C --json
mkdir -p $O/run $O/run16; for f in config.json timings.jsonl summary.json gate.json gate_states.npz compile_ahead.log compile_ahead_gate.log; do cp $R/$f $O/run/ 2>/dev/null; done
mkdir -p $R16; for f in $R/*; do b=$(basename $f); case $b in gate.json|gate_states.npz|run.lock) ;; *) ln -s $f $R16/$b;; esac; done
cp $R/gate.json $R/gate_states.npz $R16/
ev 0.3 refit16 python -m vags_jax.stages.gate_measure --run $R16 --refit --bins 16
cp $R16/gate.json $R16/gate_states.npz $O/run16/
for part in "11,12,13 ." "14,15,16 more"; do
  set -- $part; SE=$1; D=$O/$2
  ev 0.3 vags_nv_$2 python eval.py --run $R --no-viewpoint --seeds $SE --cache-dir $C --out "$D/seed{seed}/eval_vags-no-viewpoint.json" &
  ev 0.3 vags_$2 python eval.py --run $R --seeds $SE --cache-dir $C --out "$D/seed{seed}/eval_vags.json" &
  ev 0.3 vags16_$2 python eval.py --run $R16 --seeds $SE --cache-dir $C --out "$D/bins16/seed{seed}/eval_vags.json" &
  wait
  echo "g$N evals $2 done $(date +%T)" >> $L
done
if [ -n "$SWEEP" ]; then
  ev 0.9 sweep16 python eval.py --run $R16 --seed 11 --rounds 20 --threshold-sweep=-0.25:0.25:0.05 --cache-dir $C --out "$O/bins16/sweep/eval_vags_r20.json"
fi
echo "g$N chain done $(date +%T)" >> $L
