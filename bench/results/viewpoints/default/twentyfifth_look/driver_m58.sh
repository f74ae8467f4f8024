#!/usr/bin/env bash
# Issue 23, twenty-fifth look: does the grasp after a move pay more when the success net scores
# the fused maps' cells (vags.close_score=success, the mean over a grasp and its half turn)
# instead of GDNet's Q?  The `gpu` pipeline (its table measured with "q"), then the table
# measured again on the same piles with "success" and the GDNets the run kept; VAGS under each
# and the ablation, seeds 11-13, groups 1-10 x 50 rounds.
# The rule, fixed before anything ran: "success" becomes the default where, on both trainings,
# the grasp after a move on the tables' paired states gains more than twice its standard error
# and VAGS's mean 6-10 margin over the three seeds is not lower than with "q".
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
cd $S
N=${1:-58}
O=/root/runs/o$N; log=$O/machine_log.txt; mkdir -p $O; C=/root/cc
R=/root/runs/g$N; R2=/root/runs/g${N}s
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $O/$k.txt 2>&1; rc=$?; echo "$k rc=$rc $(( $(date +%s)-t )) s $(date +%T)" >> $log; return $rc; }
ev() { f=$1; shift; XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=$f run "$@"; }
keep() { mkdir -p $O/$2; for f in config.json timings.jsonl summary.json gate.json gate_states.npz compile_ahead.log compile_ahead_gate.log; do cp $1/$f $O/$2/ 2>/dev/null; done; }
run train timeout 1000 python train.py --config gpu --out $R --cache-dir $C --json
keep $R q
PICK=$(python -c "
import json; d = json.load(open('$R/gate.json')); t = d.get('gdnet_pick', {})
print(next((k for k, v in t.items() if v['gdnet'] == d['gdnet'] and v['close_gdnet'] == d['close_gdnet']), 'stage3'))")
echo "gdnet pick $PICK" >> $log
mkdir -p $R2; for f in $R/*; do case $(basename $f) in gate.json|gate_states.npz) ;; *) ln -s $f $R2/;; esac; done
ev 0.45 measure python -m vags_jax.stages.gate_measure --run $R2 --close-score success --gdnet $PICK &
ev 0.45 vags_nv python eval.py --run $R --no-viewpoint --seeds 11,12,13 --cache-dir $C --out "$O/seed{seed}/eval_vags-no-viewpoint.json" &
wait
keep $R2 success
run paired python bench/paired_tables.py $R $R2 --names q success --json $O/paired.json
ev 0.45 vags_q python eval.py --run $R --seeds 11,12,13 --cache-dir $C --out "$O/seed{seed}/eval_vags.json" &
ev 0.45 vags_s python eval.py --run $R2 --set vags.close_score=success --seeds 11,12,13 --cache-dir $C --out "$O/success/seed{seed}/eval_vags.json" &
wait
echo "done $(date +%T)" >> $log
