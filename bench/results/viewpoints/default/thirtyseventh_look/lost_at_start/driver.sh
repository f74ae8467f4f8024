#!/usr/bin/env bash
# Written on 2026-12-07 before its device call.  How many objects of the benchmark's piles of
# 6-10 objects are gone before the round's first attempt (spilled out of the workspace by the
# pile's drop)?  The scenes do not depend on the policy, so the scripted heuristic plays them
# (no trained run needed): the gpu preset, groups 6-10 x 50 rounds, seed 11, as the looks' tables.
# On ONE bare H100 (or H200), after the wheels.
S=${S:-/root/src}
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1 CUDA_VISIBLE_DEVICES=0
cd $S
mkdir -p $OUT/lost_at_start
timeout ${LIMIT:-280} python eval.py --config gpu --policy heuristic --groups 6,7,8,9,10 --rounds 50 --seeds 11 \
  --cache-dir /root/cc --out "$OUT/lost_at_start/seed{seed}/eval_heuristic.json" > $OUT/lost_at_start/eval.txt 2>&1
echo "rc=$?" >> $OUT/lost_at_start/eval.txt
python - <<'PY'
import json, os
p = os.path.join(os.environ["OUT"], "lost_at_start", "seed11", "eval_heuristic.json")
if os.path.exists(p):
    r = json.load(open(p))
    for g in r["groups_metrics"]:
        print(g["n_objects"], "objects: rounds", g["rounds"], "lost", g["objects_lost"], "of them at start",
              g.get("objects_lost_at_start"), "clearing", g["clearing_rate"])
PY
