#!/usr/bin/env bash
# Issue 23, thirtieth look: is the margin of VAGS over its ablation the viewpoint's, or the
# planner's?  After a move the gpu preset grasps at the success net's half-turn-mean argmax
# (vags.close_score=success); its ablation (--no-viewpoint) grasps at GDNet's argmax.
# vags.direct_score=success plans the direct grasp with the same score on the global maps.
# One new training of the gpu preset (seed 14); its table as the pipeline measured it ("q"
# direct grasps), then measured again on the same GDNets with "success" direct grasps (the
# states also hold GDNet's direct grasp, "gdnet_*"); the ablation and VAGS under each planner,
# seeds 11-13, groups 1-10 x 50 rounds.
# The rule, fixed before anything ran (bench/RESULTS.md, thirtieth look): direct_score=success
# becomes the gpu preset's default if, on every seed of 11-13, VAGS with it grasps at least as
# well overall as VAGS with "q" and at a lower motion number; the margin is then taken
# against the ablation with the same direct planner.
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
cd $S
N=${1:-70}
O=/root/runs/o$N; log=$O/machine_log.txt; mkdir -p $O; C=/root/cc
R=/root/runs/g$N; R2=/root/runs/g${N}s
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $O/$k.txt 2>&1; rc=$?; echo "$k rc=$rc $(( $(date +%s)-t )) s $(date +%T)" >> $log; return $rc; }
ev() { f=$1; shift; XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=$f run "$@"; }
keep() { mkdir -p $O/$2; for f in config.json timings.jsonl summary.json gate.json gate_states.npz; do cp $1/$f $O/$2/ 2>/dev/null; done; }
E="--seeds 11,12,13 --cache-dir $C"
run train timeout 1000 python train.py --config gpu --set seed=14 --out $R --cache-dir $C --json
keep $R q
PICK=$(python -c "
import json; d = json.load(open('$R/gate.json')); t = d.get('gdnet_pick', {})
print(next((k for k, v in t.items() if v['gdnet'] == d['gdnet'] and v['close_gdnet'] == d['close_gdnet']), 'stage3'))")
echo "gdnet pick $PICK" >> $log
mkdir -p $R2; for f in $R/*; do case $(basename $f) in gate.json|gate_states.npz) ;; *) ln -s $f $R2/;; esac; done
ev 0.4 measure python -m vags_jax.stages.gate_measure --run $R2 --direct-score success --gdnet $PICK &
ev 0.25 abl_q python eval.py --run $R --no-viewpoint $E --out "$O/q/seed{seed}/eval_vags-no-viewpoint.json" &
ev 0.25 vags_q python eval.py --run $R $E --out "$O/q/seed{seed}/eval_vags.json" &
wait
keep $R2 success
ev 0.3 abl_s python eval.py --run $R --no-viewpoint --set vags.direct_score=success $E --out "$O/success/seed{seed}/eval_vags-no-viewpoint.json" &
ev 0.3 vags_s python eval.py --run $R2 --set vags.direct_score=success $E --out "$O/success/seed{seed}/eval_vags.json" &
wait
echo "done $(date +%T)" >> $log
