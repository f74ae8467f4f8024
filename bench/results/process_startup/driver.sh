#!/usr/bin/env bash
# Written on 2026-12-07, before the device call that runs it (not yet run).  Issue 27: where an
# eval.py process's fixed seconds go on the GPU (the fortieth look's warm VAGS process: 9.0 s of
# imports, 3.0 s of inputs, 10.1 s loading 63 programs in its table; 42.5 s in all against the
# goal of 40 s).  bench/process_startup.py twice (the second run's imports come from warm page
# caches and written .pyc files, as a later eval.py's do).  About 1 minute on ONE machine, after
# the wheels; it can follow another driver on the same warm machine (it writes under $RES/startup).
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1 CUDA_VISIBLE_DEVICES=0
cd $S
RES=${RES:-/root/res}/startup
mkdir -p $RES
for i in 1 2; do
  python bench/process_startup.py --programs 60 --out $RES/startup_$i.json > $RES/startup_$i.txt 2>&1
  echo "startup_$i rc=$? $(date +%T)" >> $RES/log.txt
done
