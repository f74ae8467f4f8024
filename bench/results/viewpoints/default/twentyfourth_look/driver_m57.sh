#!/usr/bin/env bash
# Issue 23: which of the success net's estimates of GDNet's grasp ranks the direct grasp's outcome
# best, and does the rate gate binned on it pay.  The `gpu` pipeline on a bare machine (its gate
# table binned on the "grasp" estimate, every estimate recorded in gate_states.npz), then
# bench/gate_estimates.py; the table refit on the estimate it picks (by the table's own picks per
# hour; "symmetric" when it picks "grasp"); VAGS with both tables, a repeat of the first (the
# benchmark's noise), and the ablation, seeds 11-13, groups 1-10 x 50 rounds.
# The second run, on the same machine right after (caches warm): driver_m56.sh with the run names changed and the repeat replaced by
# VAGS under a "window" table.  Its table picked "window" itself, so vags_e and vags_w played the
# same gate and wrote the same report paths: window/seed<S>/ holds whichever finished a seed last
# (vags_w's figures, by its log); vags_e.txt keeps the other evaluation's tables.
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
cd $S
O=/root/runs/o57; log=$O/machine_log.txt; mkdir -p $O; C=/root/cc
R=/root/runs/g57; R2=/root/runs/g57e
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $O/$k.txt 2>&1; rc=$?; echo "$k rc=$rc $(( $(date +%s)-t )) s $(date +%T)" >> $log; return $rc; }
ev() { f=$1; shift; XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=$f run "$@"; }
keep() { mkdir -p $O/$2; for f in config.json timings.jsonl summary.json gate.json gate_states.npz compile_ahead.log compile_ahead_gate.log; do cp $1/$f $O/$2/ 2>/dev/null; done; }
run train timeout 1000 python train.py --config gpu --out $R --cache-dir $C --json
keep $R cold
run estimates python bench/gate_estimates.py $R --json $O/estimates.json
E=$(python -c "import json; p = json.load(open('$O/estimates.json'))['pick']; print(p if p != 'grasp' else 'symmetric')")
BINS=$(python -c "import json; print(len(json.load(open('$R/gate.json'))['states']))")
echo "estimate $E bins $BINS" >> $log
mkdir -p $R2; for f in $R/*; do case $(basename $f) in gate.json|gate_states.npz) cp $f $R2/;; *) ln -s $f $R2/;; esac; done
run refit python -m vags_jax.stages.gate_measure --run $R2 --refit --bins $BINS --estimate $E
keep $R2 refit_$E
ev 0.45 vags python eval.py --run $R --seeds 11,12,13 --cache-dir $C --out "$O/seed{seed}/eval_vags.json" &
ev 0.45 vags_nv python eval.py --run $R --no-viewpoint --seeds 11,12,13 --cache-dir $C --out "$O/seed{seed}/eval_vags-no-viewpoint.json" &
wait
ev 0.45 vags_e python eval.py --run $R2 --set vags.gate_estimate=$E --seeds 11,12,13 --cache-dir $C --out "$O/$E/seed{seed}/eval_vags.json" &
mkdir -p /root/runs/g57w; for f in $R/*; do case $(basename $f) in gate.json|gate_states.npz) cp $f /root/runs/g57w/;; *) ln -s $f /root/runs/g57w/;; esac; done; run refit_w python -m vags_jax.stages.gate_measure --run /root/runs/g57w --refit --bins $BINS --estimate window; ev 0.45 vags_w python eval.py --run /root/runs/g57w --set vags.gate_estimate=window --seeds 11,12,13 --cache-dir $C --out "$O/window/seed{seed}/eval_vags.json" &
wait
echo "done $(date +%T)" >> $log
