"""Reads the gzipped (or plain) JSON reports of eval.py kept under bench/results/viewpoints/ and
prints the rows of bench/RESULTS.md's viewpoint tables; imported by each run's tables.py."""
import gzip
import json
import os


def report(path):
    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rt") as f:
        return json.load(f)


def find(folder, name):
    """The report ``name`` (e.g. "eval_vags") in ``folder``, as NAME.json or NAME.json.gz."""
    for p in (os.path.join(folder, name + ".json"), os.path.join(folder, name + ".json.gz")):
        if os.path.isfile(p):
            return report(p)
    raise FileNotFoundError(os.path.join(folder, name))


def row(d):
    """overall success, 6-10 success, 6-10 clearing, motion number, moves %, moves at 1 object %, picks/h"""
    o, groups = d["overall"], d["groups_metrics"]
    big = [g for g in groups if g["n_objects"] >= 6]
    s610 = sum(g["successes"] for g in big) / sum(g["attempts"] for g in big)
    c610 = sum(g["clearing_rate"] * g["rounds"] for g in big) / sum(g["rounds"] for g in big)
    one = [g for g in groups if g["n_objects"] == 1][0]
    return (100 * o["grasp_success_rate"], 100 * s610, 100 * c610, o["motion_number"], 100 * o["viewpoint_rate"],
            100 * one["viewpoint_rate"], o["picks_per_hour"])


def table(title, cases):
    """Prints one markdown table; cases: (seed, networks, policy, report) tuples."""
    print(f"\n{title}\n")
    print("| seed | networks | policy | success % | 6-10 success % | 6-10 clearing % | motion number | moves % | "
          "moves at 1 object % | picks/h |")
    print("|---:|---|---|---:|---:|---:|---:|---:|---:|---:|")
    for seed, nets, policy, d in cases:
        r = row(d)
        print(f"| {seed} | {nets} | {policy} | {r[0]:.1f} | {r[1]:.1f} | {r[2]:.1f} | {r[3]:.3f} | {r[4]:.1f} | "
              f"{r[5]:.1f} | {r[6]:.0f} |")


def differences(title, columns, rows):
    """Prints a markdown table of differences in points: columns (names after "seed"), rows
    (seed, value, ...) tuples, each value signed to one decimal."""
    print(f"\n{title}\n")
    print("| seed | " + " | ".join(columns) + " |")
    print("|---:|" + "---:|" * len(columns))
    for r in rows:
        print("| " + " | ".join([str(r[0])] + [f"{x:+.1f}" for x in r[1:]]) + " |")


def branches_table(label, rows):
    """Prints the by-branch table: label names the second column ("networks", "scenes"); rows
    (seed, label value, VAGS direct, after a move, first attempts, ablation first attempts)
    tuples of fractions."""
    print(f"\n| seed | {label} | VAGS: direct grasps % | VAGS: grasps after a move % | VAGS: first attempts % | "
          "ablation: first attempts % |\n|---:|---|---:|---:|---:|---:|")
    for s, name, d, m, f, fn in rows:
        print(f"| {s} | {name} | {100 * d:.1f} | {100 * m:.1f} | {100 * f:.1f} | {100 * fn:.1f} |")
