#!/usr/bin/env python3
"""The thirty-eighth look's tables (bench/RESULTS.md): piles spilled before the first attempt
and what benchmark.redraw_spilled does to them (the heuristic), then the s54 training's VAGS and
--no-viewpoint with and without redraws: the goals, where objects are lost, and how many rounds
of the two policies played different scenes.

    python bench/results/viewpoints/default/thirtyeighth_look/tables.py
"""
import gzip
import json
import os
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, *[".."] * 5))


def load(path):
    with gzip.open(path + ".gz", "rt") as f:
        return json.load(f)


def per_round(report, field, groups=range(6, 11)):
    return np.concatenate([np.asarray(report["outcomes"][str(k)][field]) for k in groups])


def lost(report, groups=range(6, 11)):
    return per_round(report, "n_objects", groups) - per_round(report, "successes", groups) - per_round(report, "remaining", groups)


print("## The heuristic, groups 6-10 x 50 rounds\n")
print("| seed | redraw_spilled | rounds starting with an object gone | objects gone at start | rounds redrawn"
      " (most redraws of one) | objects lost in all | clearing % | success % | wall s |")
print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
for seed in (11, 12, 13):
    for r in (0, 10):
        rep = load(os.path.join(HERE, f"heuristic/r{r}/seed{seed}/eval_heuristic.json"))
        o = rep["overall"]
        start = per_round(rep, "lost_at_start")
        redraws = per_round(rep, "redraws")
        print(f"| {seed} | {r} | {int((start > 0).sum())} of {start.size} | {int(start.sum())} | {int((redraws > 0).sum())}"
              f" ({int(redraws.max())}) | {o['objects_lost']} | {100 * o['clearing_rate']:.1f} | "
              f"{100 * o['grasp_success_rate']:.1f} | {rep['wall_s']} |")

print("\n## s54: VAGS against --no-viewpoint, with and without redraws\n")
for r in (10, 0):
    print(f"### benchmark.redraw_spilled={r}\n", flush=True)
    subprocess.run([sys.executable, os.path.join(ROOT, "bench/viewpoint_goals.py"), os.path.join(HERE, f"s54/r{r}"),
                    "--goals"], check=True)
    print(flush=True)

print("### Where the objects of the 6-10 piles are lost (three seeds pooled)\n")
print("| redraw_spilled | policy | attempts | after a move | objects lost | gone at start | lost by attempts after a move"
      " (per such attempt) | lost by direct attempts (per attempt) | rounds with an object lost | cleared |")
print("|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|")
for r in (10, 0):
    for pol in ("vags", "vags-no-viewpoint"):
        t = dict(att=0, mv=0, lost=0, start=0, lam=0, losing=0, cleared=0)
        for seed in (11, 12, 13):
            rep = load(os.path.join(HERE, f"s54/r{r}/seed{seed}/eval_{pol}.json"))
            lo = lost(rep)
            t["att"] += int(per_round(rep, "attempts").sum())
            t["mv"] += int(per_round(rep, "viewpoints").sum())
            t["lost"] += int(lo.sum())
            t["start"] += int(per_round(rep, "lost_at_start").sum())
            t["lam"] += int(per_round(rep, "lost_after_move").sum())
            t["losing"] += int((lo > 0).sum())
            t["cleared"] += int((per_round(rep, "successes") >= per_round(rep, "n_objects")).sum())
        direct = t["lost"] - t["start"] - t["lam"]
        after = f"{t['lam']} ({100 * t['lam'] / t['mv']:.1f} %)" if t["mv"] else "-"
        print(f"| {r} | {pol} | {t['att']} | {t['mv']} | {t['lost']} | {t['start']} | {after} | "
              f"{direct} ({100 * direct / (t['att'] - t['mv']):.1f} %) | {t['losing']} of 750 | {t['cleared']} of 750 |")

print("\n### Did the two policies play the same scenes? (6-10 rounds)\n")
print("| redraw_spilled | seed | scene digests equal | rounds whose redraw count differs between the two |")
print("|---:|---:|---|---:|")
for r in (10, 0):
    for seed in (11, 12, 13):
        a = load(os.path.join(HERE, f"s54/r{r}/seed{seed}/eval_vags.json"))
        b = load(os.path.join(HERE, f"s54/r{r}/seed{seed}/eval_vags-no-viewpoint.json"))
        diff = int((per_round(a, "redraws") != per_round(b, "redraws")).sum())
        print(f"| {r} | {seed} | {'yes' if a['scenes'] == b['scenes'] else 'no'} | {diff} of 250 |")

print("\n### Objects knocked off on the same states: the gate tables (RUN/gate.json's `lost`)\n")
LOOKS = ("thirtieth", "thirtysecond", "thirtythird", "thirtyfourth", "thirtyfifth", "thirtysixth",
         "thirtyseventh", "thirtyeighth")
sys.path.insert(0, os.path.join(ROOT, "bench"))
import viewpoint_goals  # noqa: E402

print("\n".join(viewpoint_goals.gate_lost_table(os.path.join(HERE, ".."), LOOKS)))
