#!/usr/bin/env bash
# Issue 23 on two trained gpu runs (vp: RESULTS' second run, warm: its third): the states table with
# the grasp-view and re-look branches, then VAGS with vags.viewpoint=grasp and the default, seeds 11-13.
cd "$(dirname "$0")/.."
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
CC=/root/vags-cc; O=runs/o6
log=runs/m6.log; mkdir -p $O; echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
for R in vp warm; do
  for objs in 6-10 1-5; do
    t0=$(date +%s); python bench/viewpoint_states.py --run runs/$R --objects $objs --worlds 256 --steps 3 \
      --out $O/$R/states_$objs.json --rows $O/$R/states_$objs.npz > $O/$R.states_$objs.txt 2>&1
    echo "$R states $objs rc=$? $(( $(date +%s) - t0 )) s $(date +%T)" >> $log
  done
done
for R in vp warm; do
  for pol in vags-grasp-view vags; do
    flag=""; [ $pol = vags-grasp-view ] && flag="--set vags.viewpoint=grasp"
    t0=$(date +%s); python eval.py --run runs/$R $flag --seeds 11,12,13 --cache-dir $CC --out "$O/$R/seed{seed}/eval_$pol.json" > $O/$R.$pol.txt 2>&1
    echo "$R $pol rc=$? $(( $(date +%s) - t0 )) s $(date +%T)" >> $log
  done
done
touch runs/m6_done
