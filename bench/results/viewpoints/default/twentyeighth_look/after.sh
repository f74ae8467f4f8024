#!/usr/bin/env bash
# Run by hand after driver.sh, on the same machine, as one command. Its "&" put the cd and the
# exports into the sweep's background subshell only, so the seed_runs.py call for seeds 14-16 ran
# from the wrong folder without the wheels' PYTHONPATH: every one of its evaluations failed in 1-2 s
# (machine_log.txt, "rc=1"), and seeds 14-16 were not measured. The sweep ran as intended.
cd /root/src && export PYTHONPATH=/root/vags-site:/root/src PYTHONUNBUFFERED=1 && O=/root/runs/look && (CUDA_VISIBLE_DEVICES=0 timeout 230 python eval.py --run $O/s6/run --seed 11 --rounds 20 --threshold-sweep=-0.25:0.25:0.05 --set vags.max_motion_number=1.28 --cache-dir $O/cache/gpu0 --out "$O/s6/sweep/eval_vags_r20.json" > $O/s6/sweep.txt 2>&1; echo "sweep rc=$?" >> $O/log.txt) & (timeout 230 python scripts/seed_runs.py --seeds 6,7,8,9 --out /root/runs/look --per-gpu 2 --eval-seeds 14,15,16 --eval ablation=--no-viewpoint --eval cap1.28="--set vags.max_motion_number=1.28" > $O/second.txt 2>&1; echo "second rc=$?" >> $O/log.txt); wait; python scripts/seed_runs.py --summary $O > $O/summary.md 2>&1
