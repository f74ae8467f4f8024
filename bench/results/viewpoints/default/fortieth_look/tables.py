#!/usr/bin/env python3
"""The fortieth look's tables (bench/RESULTS.md): a training under the re-drop default (s56), VAGS
against --no-viewpoint with the benchmark's defaults and again with benchmark.redrop_spilled=0,
whether the two played the same draws, one VAGS table timed alone, the heuristic on the edge
scenes with and without re-drops (thirtyninth_look/edge.sh, run in this look), and the knocked-off
objects on the same states over every gate table since the thirtieth look.

    python bench/results/viewpoints/default/fortieth_look/tables.py
"""
import json
import os
import re
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
TOP = os.path.dirname(HERE)
ROOT = os.path.abspath(os.path.join(HERE, *[".."] * 5))
SEEDS = (11, 12, 13)
sys.path.insert(0, os.path.join(ROOT, "bench"))
import viewpoint_goals  # noqa: E402

load = viewpoint_goals.read_report  # a committed report is gzipped beside its name


def per_round(report, field, groups=range(6, 11)):
    return np.concatenate([np.asarray(report["outcomes"][str(k)][field]) for k in groups])


print("## The pipeline (s56/timings.jsonl; a bare machine, empty cache)\n")
print("| stage | wall s | compiling s |")
print("|---|---:|---:|")
with open(os.path.join(HERE, "s56/timings.jsonl")) as f:
    for line in f:
        t = json.loads(line)
        print(f"| {t['stage']} | {t['wall_s']} | {(t.get('compile') or {}).get('seconds', '-')} |")
with open(os.path.join(HERE, "s56/summary.json")) as f:
    print(f"\ntrain.py's own clock: {json.load(f)['wall_s']} s")

for sub, what in (("s56", "the benchmark's defaults (10 re-drops)"), ("s56/d0", "benchmark.redrop_spilled=0")):
    print(f"\n## s56, VAGS against --no-viewpoint, {what}\n", flush=True)
    subprocess.run([sys.executable, os.path.join(ROOT, "bench/viewpoint_goals.py"), os.path.join(HERE, sub), "--goals"],
                   check=True)

print("\n## Did the two policies play the same draws? (groups 1-10)\n")
print("| protocol | seed | scene digests equal | rounds whose re-drop count differs between the two |")
print("|---|---:|---|---:|")
for sub in ("s56", "s56/d0"):
    for seed in SEEDS:
        a = load(os.path.join(HERE, f"{sub}/seed{seed}/eval_vags.json"))
        b = load(os.path.join(HERE, f"{sub}/seed{seed}/eval_vags-no-viewpoint.json"))
        g = range(1, 11)
        diff = int((per_round(a, "redraws", g) != per_round(b, "redraws", g)).sum())
        print(f"| {a['spilled_remedy']} | {seed} | {'yes' if a['scenes'] == b['scenes'] else 'no'} | {diff} of 500 |")

print("\n## One 500-round VAGS table alone on the warm cache (seed 11)\n")
rep = load(os.path.join(HERE, "s56/alone/eval_vags.json"))
with open(os.path.join(HERE, "vags_alone.txt")) as f:
    text = f.read()
real = re.search(r"real\s+(\d+)m([\d.]+)s", text)
own = re.search(r"done: ([\d.]+) s in this process", text)
p = rep["process_s"]
print("| whole process (`time`) | the process's own clock | imports | inputs | the table (`wall_s`) | programs compiled / loaded (s) |")
print("|---:|---:|---:|---:|---:|---|")
print(f"| {60 * int(real.group(1)) + float(real.group(2)):.1f} s | {own.group(1)} s | {p['imports_s']} s | {p['inputs_s']} s | "
      f"{rep['wall_s']} s | {rep['compile']['compiled']} / {rep['compile']['loaded']} ({rep['compile']['seconds']} s) |")

print("\n## The heuristic on the edge scenes, groups 6-10 x 50 rounds (thirtyninth_look/edge.sh)\n")
print("| run | seed | scenes digest | rounds starting with an object gone | objects gone at start |"
      " rounds redone (most re-drops of one) | objects lost in all | clearing % | success % |")
print("|---|---:|---|---:|---:|---:|---:|---:|---:|")
spilled = {}
for run in ("default", "d0"):
    spilled[run] = 0
    for seed in SEEDS:
        r = load(os.path.join(TOP, f"thirtyninth_look/edge/{run}/seed{seed}/eval_heuristic.json"))
        o = r["overall"]
        start, redone = per_round(r, "lost_at_start"), per_round(r, "redraws")
        spilled[run] += int((start > 0).sum())
        print(f"| {run} {r['spilled_remedy']} | {seed} | {r['scenes']} | {int((start > 0).sum())} of {start.size} | "
              f"{int(start.sum())} | {int((redone > 0).sum())} ({int(redone.max())}) | {o['objects_lost']} | "
              f"{100 * o['clearing_rate']:.1f} | {100 * o['grasp_success_rate']:.1f} |")
print("\n" + ", ".join(f"{run}: {n} of 750 rounds start spilled ({100 * n / 750:.1f} %)" for run, n in spilled.items()))

print("\n## Objects knocked off on the same states: the gate tables (RUN/gate.json's `lost`)\n")
LOOKS = ("thirtieth", "thirtysecond", "thirtythird", "thirtyfourth", "thirtyfifth", "thirtysixth",
         "thirtyseventh", "thirtyeighth", "thirtyninth", "fortieth")
print("\n".join(viewpoint_goals.gate_lost_table(TOP, LOOKS)))
