#!/usr/bin/env python3
"""The thirty-ninth look's tables (bench/RESULTS.md): benchmark.redrop_spilled on the heuristic
(two runs with 10 re-drops, one without) against the rule fixed in driver.sh, then the s55
training's VAGS and --no-viewpoint with 10 re-drops: the goals, where objects are lost, whether
the two played the same draws, and the gate tables' knocked-off objects on the same states.

    python bench/results/viewpoints/default/thirtyninth_look/tables.py
"""
import gzip
import json
import os
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, *[".."] * 5))
SEEDS = (11, 12, 13)


def load(path):
    with gzip.open(path + ".gz", "rt") as f:
        return json.load(f)


def per_round(report, field, groups=range(6, 11)):
    return np.concatenate([np.asarray(report["outcomes"][str(k)][field]) for k in groups])


def lost(report, groups=range(6, 11)):
    return per_round(report, "n_objects", groups) - per_round(report, "successes", groups) - per_round(report, "remaining", groups)


print("## The heuristic, groups 6-10 x 50 rounds\n")
print("| run | redrop_spilled | seed | scenes digest | rounds starting with an object gone | objects gone at start |"
      " rounds redone (most re-drops of one) | objects lost in all | clearing % | success % | wall s |")
print("|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|")
runs = {"d10a": 10, "d0": 0, "d10b": 10}
spilled, wall, digests = {}, {}, {}
for run, n in runs.items():
    spilled[run], wall[run] = 0, 0.0
    for seed in SEEDS:
        rep = load(os.path.join(HERE, f"heuristic/{run}/seed{seed}/eval_heuristic.json"))
        o = rep["overall"]
        start, redone = per_round(rep, "lost_at_start"), per_round(rep, "redraws")
        spilled[run] += int((start > 0).sum())
        wall[run] += rep["wall_s"]
        digests[run, seed] = rep["scenes"]
        print(f"| {run} | {n} | {seed} | {rep['scenes']} | {int((start > 0).sum())} of {start.size} | {int(start.sum())} | "
              f"{int((redone > 0).sum())} ({int(redone.max())}) | {o['objects_lost']} | {100 * o['clearing_rate']:.1f} | "
              f"{100 * o['grasp_success_rate']:.1f} | {rep['wall_s']} |")

print("\n### The rule fixed in driver.sh before the run\n")
print("| part | figure | met |")
print("|---|---|---|")
for run in ("d10a", "d10b"):
    share = 100 * spilled[run] / 750
    print(f"| (a) under 1 % of the 750 rounds of {run} start spilled | {spilled[run]} rounds, {share:.2f} % | "
          f"{'yes' if share < 1 else 'no'} |")
same = all(digests["d10a", s] == digests["d10b", s] for s in SEEDS)
print(f"| (b) d10a's and d10b's scene digests equal on every seed | "
      f"{', '.join(digests['d10a', s] == digests['d10b', s] and 'equal' or 'differ' for s in SEEDS)} | {'yes' if same else 'no'} |")
ratio = wall["d10b"] / wall["d0"]
print(f"| (c) d10b under 1.5 x d0's time (wall_s summed over seeds, run side by side) | {wall['d10b']:.2f} s against "
      f"{wall['d0']:.2f} s, {ratio:.2f} x | {'yes' if ratio < 1.5 else 'no'} |")

print("\n## s55: VAGS against --no-viewpoint with benchmark.redrop_spilled=10\n", flush=True)
subprocess.run([sys.executable, os.path.join(ROOT, "bench/viewpoint_goals.py"), os.path.join(HERE, "s55/d10"), "--goals"],
               check=True)

print("\n### Where the objects of the 6-10 piles are lost (three seeds pooled)\n")
print("| policy | attempts | after a move | objects lost | gone at start | lost by attempts after a move (per such attempt)"
      " | lost by direct attempts (per attempt) | rounds with an object lost | rounds out of attempts | cleared |")
print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
for pol in ("vags", "vags-no-viewpoint"):
    t = dict(att=0, mv=0, lost=0, start=0, lam=0, losing=0, out=0, cleared=0)
    for seed in SEEDS:
        rep = load(os.path.join(HERE, f"s55/d10/seed{seed}/eval_{pol}.json"))
        lo, n = lost(rep), per_round(rep, "n_objects")
        left = per_round(rep, "remaining")
        t["att"] += int(per_round(rep, "attempts").sum())
        t["mv"] += int(per_round(rep, "viewpoints").sum())
        t["lost"] += int(lo.sum())
        t["start"] += int(per_round(rep, "lost_at_start").sum())
        t["lam"] += int(per_round(rep, "lost_after_move").sum())
        t["losing"] += int((lo > 0).sum())
        t["out"] += int(((left > 0) & (per_round(rep, "attempts") >= 2 * n + 5)).sum())
        t["cleared"] += int((per_round(rep, "successes") >= n).sum())
    direct = t["lost"] - t["start"] - t["lam"]
    after = f"{t['lam']} ({100 * t['lam'] / t['mv']:.1f} %)" if t["mv"] else "-"
    print(f"| {pol} | {t['att']} | {t['mv']} | {t['lost']} | {t['start']} | {after} | "
          f"{direct} ({100 * direct / (t['att'] - t['mv']):.1f} %) | {t['losing']} of 750 | {t['out']} | {t['cleared']} of 750 |")

print("\n### Did the two policies play the same draws? (groups 1-10)\n")
print("| seed | scene digests equal | rounds whose re-drop count differs between the two |")
print("|---:|---|---:|")
for seed in SEEDS:
    a = load(os.path.join(HERE, f"s55/d10/seed{seed}/eval_vags.json"))
    b = load(os.path.join(HERE, f"s55/d10/seed{seed}/eval_vags-no-viewpoint.json"))
    g = range(1, 11)
    diff = int((per_round(a, "redraws", g) != per_round(b, "redraws", g)).sum())
    print(f"| {seed} | {'yes' if a['scenes'] == b['scenes'] else 'no'} | {diff} of 500 |")

print("\n### Objects knocked off on the same states: the gate tables (RUN/gate.json's `lost`)\n")
LOOKS = ("thirtieth", "thirtysecond", "thirtythird", "thirtyfourth", "thirtyfifth", "thirtysixth",
         "thirtyseventh", "thirtyeighth", "thirtyninth")
sys.path.insert(0, os.path.join(ROOT, "bench"))
import viewpoint_goals  # noqa: E402

print("\n".join(viewpoint_goals.gate_lost_table(os.path.join(HERE, ".."), LOOKS)))
