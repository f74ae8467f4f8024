"""Prints the tables of driver.sh in this directory: both pipelines' wall clocks and stages
(bench/pipeline_times.py); the benchmark of GDNet alone and of VAGS with the direct grasp at
GDNet's argmax (`vags.direct_score=q`, r48 and r49) and at the argmax of its half-turn mean
(`q_mean`, r48m and r49m), on the same networks and seeds; the two direct grasps paired on the
q_mean tables' states (each state grasped both ways); each run against issue 23's goals
(bench/viewpoint_goals.py); the grasps after a move against the direct ones on each table's
moving bins; the grasp loop's physics at 512 and 1,024 worlds
(bench/physics_profile.py).  Run from anywhere:
python bench/results/viewpoints/default/thirtyfifth_look/tables.py"""
import json
import math
import os
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", "..", "..", "..", ".."))
sys.path.insert(0, os.path.join(ROOT, "bench"))
RUNS = (("r48", "cold (empty cache)"), ("r49", "from r48's cache"))
SEEDS = (11, 12, 13)
GROUPS = (("all", 1, 10), ("1", 1, 1), ("2-5", 2, 5), ("6-10", 6, 10))


def timing_table(here=HERE, runs=RUNS):
    from pipeline_times import table
    print(table(here, runs))


def benchmark_table(here=HERE, runs=RUNS):
    """Per training and policy: q and q_mean side by side, by seed, and the difference."""
    from viewpoint_goals import read_report, row
    print("\n| run | policy | seed | success: q | q_mean | q_mean - q | 6-10 success: q | q_mean | 6-10 clearing: q | "
          "q_mean | motion number: q | q_mean | at 1 object, viewpoint %: q | q_mean |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for run, _ in runs:
        for pol in ("vags-no-viewpoint", "vags"):
            diffs = []
            for seed in SEEDS:
                a = row(read_report(os.path.join(here, run, f"seed{seed}", f"eval_{pol}.json")))
                b = row(read_report(os.path.join(here, f"{run}m", f"seed{seed}", f"eval_{pol}.json")))
                diffs.append(b["success"] - a["success"])
                print(f"| {run} | {pol} | {seed} | {100 * a['success']:.1f} | {100 * b['success']:.1f} | "
                      f"{100 * diffs[-1]:+.1f} | {100 * a['success_6_10']:.1f} | {100 * b['success_6_10']:.1f} | "
                      f"{100 * a['clearing_6_10']:.1f} | {100 * b['clearing_6_10']:.1f} | {a['motion_number']:.2f} | "
                      f"{b['motion_number']:.2f} | {100 * a['viewpoint_1']:.1f} | {100 * b['viewpoint_1']:.1f} |")
            print(f"| {run} | {pol} | mean | | | {100 * sum(diffs) / len(diffs):+.1f} | | | | | | | | |")


def paired_table(here=HERE, runs=RUNS):
    """The q_mean tables' states: the direct grasp at q_mean's argmax (`direct_success`) and at
    GDNet's plain argmax (`gdnet_success`) from each state, with the paired difference's
    standard error."""
    print("\n| table | GDNets | objects | states | q % | q_mean % | q_mean - q (points) |")
    print("|---|---|---|---:|---:|---:|---:|")
    for run, _ in runs:
        d = os.path.join(here, f"{run}m")
        s = np.load(os.path.join(d, "gate_states.npz"))
        with open(os.path.join(d, "gate.json")) as f:
            gdnet = json.load(f)["gdnet"]
        for name, lo, hi in GROUPS:
            m = (s["objects"] >= lo) & (s["objects"] <= hi)
            q, qm = s["gdnet_success"][m].astype(float), s["direct_success"][m].astype(float)
            diff = qm - q
            se = diff.std(ddof=1) / math.sqrt(len(diff))
            print(f"| {run}m | {gdnet} | {name} | {m.sum()} | {100 * q.mean():.1f} | {100 * qm.mean():.1f} | "
                  f"{100 * diff.mean():+.1f} ± {100 * se:.1f} |")


def moving_bins_table(here=HERE, runs=RUNS, suffixes=("", "m")):
    """On each table's states in its moving bins: the grasp after a move against the direct one,
    paired (issue 23's goal that close-view grasps be at least as good where the gate moves)."""
    sys.path.insert(0, ROOT)
    from vags_jax.policies import rate_gate
    print("\n| table | moving bins | states | after a move % | direct % | paired difference (points) |")
    print("|---|---|---:|---:|---:|---:|")
    for run in [r + m for r, _ in runs for m in suffixes]:
        d = os.path.join(here, run)
        table, st = rate_gate.from_dict(rate_gate.read(d)), rate_gate.read_states(d)
        moving = rate_gate.moves_summary(table)["moving_bins"]
        m = np.isin(np.searchsorted(np.asarray(table.edges), st["p_direct"], side="right"), moving)
        moved, direct = st["moved_success"][m].astype(float), st["direct_success"][m].astype(float)
        diff = moved - direct
        print(f"| {run} | {moving} | {m.sum()} | {100 * moved.mean():.1f} | {100 * direct.mean():.1f} | "
              f"{100 * diff.mean():+.1f} ± {100 * diff.std(ddof=1) / math.sqrt(len(diff)):.1f} |")


def physics_table():
    print("\n| worlds | grasp loop ms (148 steps) | grasps/s | settle steps/s (our loop) | bare scan | "
          "bare, unrolled 4 | bare, unrolled 4, XLA graphs of size >= 1 |")
    print("|---:|---:|---:|---:|---:|---:|---:|")
    with open(os.path.join(HERE, "physics_profile_512.jsonl")) as f:
        for r in map(json.loads, f):
            print(f"| {r['worlds']:,} | {1000 * r['grasp_s']:.1f} | {r['grasps_per_s']:,.0f} | "
                  f"{r['settle_steps_per_s']:,.0f} | {r['raw_steps_per_s']:,.0f} | "
                  f"{r['raw_unroll4_steps_per_s']:,.0f} | {r['raw_unroll4_graph1_steps_per_s']:,.0f} |")


def goals_tables(here=HERE, runs=RUNS, suffixes=("", "m")):
    """Each run against issue 23's goals (bench/viewpoint_goals.py --goals)."""
    for run in [r + m for r, _ in runs for m in suffixes]:
        print(f"\n{run}:")
        sys.stdout.flush()
        subprocess.run([sys.executable, os.path.join(ROOT, "bench", "viewpoint_goals.py"), os.path.join(here, run),
                        "--goals"], check=False)


def main():
    timing_table()
    benchmark_table()
    paired_table()
    goals_tables()
    moving_bins_table()
    physics_table()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
