#!/usr/bin/env python3
"""The issue "Viewpoints that pay"'s goals from ``eval.py`` reports: one row per policy and seed.

    python bench/viewpoint_goals.py bench/results/viewpoints/default [--policies vags vags-no-viewpoint]

Reads ``DIR/seed<S>/eval_<policy>.json`` (or ``.json.gz``) and prints a Markdown table: overall success and
clearing, the same pooled over groups 6-10 (successes over attempts, cleared rounds over
rounds), motion number, viewpoint share, the viewpoint share at one object, picks per hour;
then, per seed, the first policy's gain over the second on 6-10 objects.
"""
from __future__ import annotations

import argparse
import glob
import gzip
import json
import os
import re
import sys


def read_report(path: str):
    """An eval.py report at ``path``, or gzipped beside it (``path``.gz, as committed); None if neither."""
    if os.path.isfile(path):
        with open(path) as f:
            return json.load(f)
    if os.path.isfile(path + ".gz"):
        with gzip.open(path + ".gz", "rt") as f:
            return json.load(f)
    return None


def pooled(report: dict, lo: int, hi: int) -> tuple[float, float]:
    """(grasp success, clearing) pooled over the groups of lo..hi objects."""
    rows = [g for g in report["groups_metrics"] if lo <= g["n_objects"] <= hi]
    succ = sum(g["successes"] for g in rows) / max(1, sum(g["attempts"] for g in rows))
    clear = sum(g["clearing_rate"] * g["rounds"] for g in rows) / max(1, sum(g["rounds"] for g in rows))
    return succ, clear


def row(report: dict) -> dict:
    o = report["overall"]
    one = [g for g in report["groups_metrics"] if g["n_objects"] == 1]
    s610, c610 = pooled(report, 6, 10)
    return {"success": o["grasp_success_rate"], "clearing": o["clearing_rate"], "success_6_10": s610,
            "clearing_6_10": c610, "motion_number": o["motion_number"], "viewpoint": o["viewpoint_rate"],
            "viewpoint_1": one[0]["viewpoint_rate"] if one else float("nan"), "picks_per_hour": o["picks_per_hour"]}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("dir", help="folder with seed<S>/eval_<policy>.json")
    p.add_argument("--policies", nargs="+", default=["vags", "vags-no-viewpoint"])
    args = p.parse_args(argv)
    seeds = sorted(int(re.sub(r"\D", "", os.path.basename(d))) for d in glob.glob(os.path.join(args.dir, "seed*")))
    rows = {}
    for pol in args.policies:
        for s in seeds:
            report = read_report(os.path.join(args.dir, f"seed{s}", f"eval_{pol}.json"))
            if report is not None:
                rows[pol, s] = row(report)
    if not rows:
        print(f"no reports under {args.dir}/seed*/ for {args.policies}", file=sys.stderr)
        return 2
    pct = lambda v: f"{100 * v:.1f}"  # noqa: E731
    print("| policy | seed | success | clearing | 6-10 success | 6-10 clearing | motion number | viewpoint % "
          "| at 1 object: viewpoint % | picks/h |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for (pol, s), r in rows.items():
        print(f"| {pol} | {s} | {pct(r['success'])} | {pct(r['clearing'])} | {pct(r['success_6_10'])} | "
              f"{pct(r['clearing_6_10'])} | {r['motion_number']:.2f} | {pct(r['viewpoint'])} | "
              f"{pct(r['viewpoint_1'])} | {r['picks_per_hour']:.0f} |")
    a, b = args.policies[:2] if len(args.policies) > 1 else (args.policies[0], None)
    if b is not None:
        print(f"\n| seed | 6-10 success: {a} - {b} | 6-10 clearing | overall clearing |")
        print("|---:|---:|---:|---:|")
        for s in seeds:
            if (a, s) in rows and (b, s) in rows:
                x, y = rows[a, s], rows[b, s]
                print(f"| {s} | {100 * (x['success_6_10'] - y['success_6_10']):+.1f} | "
                      f"{100 * (x['clearing_6_10'] - y['clearing_6_10']):+.1f} | {100 * (x['clearing'] - y['clearing']):+.1f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
