#!/usr/bin/env bash
# Started on the first machine right after driver_m58.sh ended (12:08 UTC): VAGS with "success"
# capped at 1.3 motions (as eval.py then ran it, the cap reached only the report: see
# first/cap_not_applied/), a repeat of VAGS with "success", then a second training on warm
# caches (driver_m58.sh 59).  The machine was given back idle during that training (more than
# 30 s between calls), so only the two evaluations below came back; driver_m59.sh trained the
# second run again on a bare machine.
S=/root/src; export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1; cd $S; C=/root/cc
run() { k=$1; shift; t=$(date +%s); "$@" > $O/$k.txt 2>&1; rc=$?; echo "$k rc=$rc $(( $(date +%s)-t )) s $(date +%T)" >> $O/machine_log.txt; }
ev() { f=$1; shift; XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=$f run "$@"; }
O=/root/runs/o58
ev 0.45 cap130 python eval.py --run /root/runs/g58s --set vags.close_score=success vags.max_motion_number=1.3 --seeds 11,12,13 --cache-dir $C --out "$O/success_cap1.3/seed{seed}/eval_vags.json" &
ev 0.45 rep_s python eval.py --run /root/runs/g58s --set vags.close_score=success --seeds 11,12,13 --cache-dir $C --out "$O/success_repeat/seed{seed}/eval_vags.json" &
wait
echo "done2 $(date +%T)" >> $O/machine_log.txt
bash /root/driver.sh 59
