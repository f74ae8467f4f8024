"""Prints the tables of driver.sh, headroom.sh and ../../../throughput/physics_settle/driver.sh:
both pipelines' wall clocks; the benchmark of GDNet alone and of VAGS under
`vags.direct_score=q` (r50, r51) and `q_mean` (r50m, r51m) on the same networks and seeds; the
rule fixed in driver.sh, applied to unrounded figures; the two direct grasps paired on the
q_mean tables' states; each run against issue 23's goals; the grasps after a move against the
direct ones on each table's moving bins; gate_headroom.py's tables (VANet's move against a
random object cell); the settle loop over 1 s at 512 worlds.  The table functions are the
thirty-fifth look's.  Run from anywhere:
python bench/results/viewpoints/default/thirtysixth_look/tables.py"""
import importlib.util
import json
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", "..", "..", "..", ".."))
sys.path.insert(0, os.path.join(ROOT, "bench"))
RUNS = (("r50", "cold (empty cache)"), ("r51", "from r50's cache"))
SEEDS = (11, 12, 13)
SETTLE = [os.path.join(ROOT, "bench", "results", "throughput", "physics_settle", f"settle{i}.jsonl") for i in (1, 2)]

_spec = importlib.util.spec_from_file_location(
    "thirtyfifth_tables", os.path.join(HERE, "..", "thirtyfifth_look", "tables.py"))
look35 = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(look35)


def rule():
    """driver.sh's rule: GDNet alone at least as good under q_mean on >= 5 of the 6 seeds, and
    VAGS's seed-mean success under q_mean at most 0.5 points below q on each training."""
    from viewpoint_goals import read_report, row
    at_least, vags_ok = 0, True
    print("\n| run | GDNet alone: seeds with q_mean >= q | VAGS: seed-mean q_mean - q (points) |")
    print("|---|---:|---:|")
    for run, _ in RUNS:
        success = lambda d, pol, s: row(read_report(  # noqa: E731
            os.path.join(HERE, d, f"seed{s}", f"eval_{pol}.json")))["success"]
        better = sum(success(f"{run}m", "vags-no-viewpoint", s) >= success(run, "vags-no-viewpoint", s)
                     for s in SEEDS)
        vags = sum(success(f"{run}m", "vags", s) - success(run, "vags", s) for s in SEEDS) / len(SEEDS)
        at_least += better
        vags_ok &= 100 * vags >= -0.5
        print(f"| {run} | {better} of {len(SEEDS)} | {100 * vags:+.2f} |")
    met = at_least >= 5 and vags_ok
    print(f"\nGDNet alone at least as good under q_mean on {at_least} of 6 seeds (rule: >= 5); VAGS within "
          f"0.5 points on both trainings: {vags_ok}.  The rule is {'met' if met else 'not met'}.")


def headroom_tables(here=HERE, runs=RUNS):
    from gate_headroom import table
    for run, _ in runs:
        path = os.path.join(here, "headroom", run, "headroom.json")
        if not os.path.exists(path):
            print(f"\nno headroom table for {run}")
            continue
        with open(path) as f:
            got = json.load(f)
        print(f"\n{run}'s gate table states ({got['measure']['live_states']} live; GDNets {got['gdnet_pick']}; "
              f"moving bins {got['moving_bins']['moving_bins']} of {got['moving_bins']['bins']}; outcomes equal to "
              f"the run's table: {got['agreement_with_run_table']}; {got['measure']['wall_s']} s on {got['device']})\n")
        print(table(got["summary"]))


def settle_table():
    """physics_profile.py --settle-seconds 1.0 at 512 worlds, two processes (physics_settle/)."""
    print("\n| process | worlds | settle s | settle steps/s (our loop) | bare scan | bare, unrolled 4 | "
          "our loop / bare scan | grasp loop ms |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for i, path in enumerate(SETTLE, 1):
        if not os.path.exists(path):
            print(f"| {i} | no figures | | | | | | |")
            continue
        with open(path) as f:
            for r in map(json.loads, f):
                print(f"| {i} | {r['worlds']:,} | {r['settle_seconds']} | {r['settle_steps_per_s']:,.0f} | "
                      f"{r['raw_steps_per_s']:,.0f} | {r['raw_unroll4_steps_per_s']:,.0f} | "
                      f"{r['settle_steps_per_s'] / r['raw_steps_per_s']:.3f} | {1000 * r['grasp_s']:.1f} |")


def main():
    look35.timing_table(HERE, RUNS)
    look35.benchmark_table(HERE, RUNS)
    rule()
    look35.paired_table(HERE, RUNS)
    look35.goals_tables(HERE, RUNS)
    look35.moving_bins_table(HERE, RUNS)
    headroom_tables()
    settle_table()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
