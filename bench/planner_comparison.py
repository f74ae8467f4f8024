#!/usr/bin/env python3
"""VAGS and its ablation with the direct grasp planned by GDNet's argmax and by the success net's,
from the files of one or more trainings (bench/RESULTS.md, "thirtieth" and "thirty-first look").

    python bench/planner_comparison.py DIR [DIR ...]

Each DIR holds ``q/`` (the pipeline's table: ``gate.json``, ``gate_states.npz``, ``config.json``,
and the reports ``seed<S>/eval_vags.json`` and ``eval_vags-no-viewpoint.json``, or ``.json.gz``)
and ``success/`` (the same for the table measured with ``gate_measure --direct-score success``,
whose states also hold GDNet's direct grasp).  Prints the benchmark rows, the 6-10 success
differences, each table's bins, and the success tables' states grasped three ways (GDNet's
argmax, the success net's argmax, after a move), paired, and a move's gain by the attempt's
index in its pile.
"""
from __future__ import annotations

import argparse
import glob
import json
import os
import re
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from viewpoint_goals import pooled, read_report, row  # noqa: E402

POLICIES = (("ablation", "q", "eval_vags-no-viewpoint.json"),
            ("VAGS", "q", "eval_vags.json"),
            ("ablation", "success", "eval_vags-no-viewpoint.json"),
            ("VAGS", "success", "eval_vags.json"))


def training_seed(folder: str) -> int:
    with open(os.path.join(folder, "q", "config.json")) as f:
        return json.load(f)["seed"]


def seeds_of(folder: str) -> list[int]:
    """The benchmark seeds with reports under ``folder/q``."""
    return sorted(int(re.fullmatch(r"seed(\d+)", os.path.basename(d)).group(1))
                  for d in glob.glob(os.path.join(folder, "q", "seed*")))


def _report(folder, planner, seed, file):
    rep = read_report(os.path.join(folder, planner, f"seed{seed}", file))
    if rep is None:
        raise SystemExit(f"planner_comparison: no report {os.path.join(folder, planner, f'seed{seed}', file)}[.gz]")
    return rep


def benchmark(folders) -> bool:
    """Prints the benchmark rows and the 6-10 differences -> whether VAGS gained at least +5
    points of 6-10 success over its ablation with the success net's direct grasp on every seed."""
    print("| training seed | direct grasp planned by | policy | seed | success % | 6-10 success % | 6-10 clearing % | "
          "motion number | moves % | moves at 1 object % | picks/h | direct grasps % | after a move % |")
    print("|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for folder in folders:
        for name, planner, file in POLICIES:
            for s in seeds_of(folder):
                rep = _report(folder, planner, s, file)
                r, o = row(rep), rep["overall"]
                after = o.get("success_after_move")
                print(f"| {training_seed(folder)} | {planner} | {name} | {s} | {100 * r['success']:.1f} | "
                      f"{100 * r['success_6_10']:.1f} | {100 * r['clearing_6_10']:.1f} | {r['motion_number']:.3f} | "
                      f"{100 * r['viewpoint']:.1f} | {100 * r['viewpoint_1']:.1f} | {r['picks_per_hour']:.0f} | "
                      f"{100 * o['success_direct']:.1f} | " + ("-" if after is None else f"{100 * after:.1f}") + " |")
    print("\n6-10 success, differences in points:")
    print("| training seed | seed | VAGS (q) over its ablation (q) | VAGS (q) over the ablation (success) | "
          "VAGS (success) over its ablation (success) | ablation (success) over ablation (q) |")
    print("|---:|---:|---:|---:|---:|---:|")
    pays = True
    for folder in folders:
        for s in seeds_of(folder):
            p = [pooled(_report(folder, pl, s, f), 6, 10)[0] for _, pl, f in POLICIES]
            pays &= 100 * (p[3] - p[2]) >= 5.0 - 1e-9  # +5.0 on the table counts, whatever the float's rounding
            print(f"| {training_seed(folder)} | {s} | {100 * (p[1] - p[0]):+.1f} | {100 * (p[1] - p[2]):+.1f} | "
                  f"{100 * (p[3] - p[2]):+.1f} | {100 * (p[2] - p[0]):+.1f} |")
    return pays


def tables(folders) -> None:
    for folder in folders:
        for planner in ("q", "success"):
            with open(os.path.join(folder, planner, "gate.json")) as f:
                t = json.load(f)
            moving = [k for k, v in enumerate(t["move_value"]) if v > 0]
            print(f"\ntraining seed {training_seed(folder)}, {planner} table ({t['live_states']} states, GDNets "
                  f"{t['gdnet']} / after a move {t['close_gdnet']}): moves in bins {moving} of "
                  f"{len(t['move_value'])}, {3600 * t['rate']:.0f} picks/h")
            print("| bin | states | direct % | after a move % | move value |")
            print("|---:|---:|---:|---:|---:|")
            for k, (n, d, m, v) in enumerate(zip(t["states"], t["direct"], t["moved"], t["move_value"])):
                print(f"| {k} | {n} | {100 * d:.1f} | {100 * m:.1f} | {v:+.3f} |")


def _mean_se(x):
    x = np.asarray(x, np.float64)
    return 100 * x.mean(), 100 * x.std(ddof=1) / np.sqrt(x.size)


def paired_states(folders) -> None:
    print("\nThe success tables' states, each grasped three ways (the piles follow the success net's direct grasp):")
    print("| training seed | states | n | GDNet's argmax % | success net's argmax % | after a move % | "
          "success net - GDNet | after a move - success net |")
    print("|---:|---|---:|---:|---:|---:|---:|---:|")
    for folder in folders:
        s = dict(np.load(os.path.join(folder, "success", "gate_states.npz")))
        g, d, m = (s[k].astype(np.float64) for k in ("gdnet_success", "direct_success", "moved_success"))
        for label, sel in (("all", np.ones_like(g, bool)), ("1 object", s["objects"] == 1),
                           ("2-5 objects", (s["objects"] >= 2) & (s["objects"] <= 5)),
                           ("6-10 objects", s["objects"] >= 6),
                           ("lowest eighth of p_direct", s["p_direct"] < np.quantile(s["p_direct"], 0.125))):
            if sel.sum() < 2:  # no mean and standard error to give
                continue
            dg, md = _mean_se(d[sel] - g[sel]), _mean_se(m[sel] - d[sel])
            print(f"| {training_seed(folder)} | {label} | {int(sel.sum())} | {100 * g[sel].mean():.1f} | "
                  f"{100 * d[sel].mean():.1f} | {100 * m[sel].mean():.1f} | {dg[0]:+.1f} +- {dg[1]:.1f} | "
                  f"{md[0]:+.1f} +- {md[1]:.1f} |")


def by_attempt(folders) -> None:
    """A move's paired gain over the success net's direct grasp by the attempt's index in its
    pile (the table's ``attempt``; 0: the first grasp at a fresh pile)."""
    print("\nAfter a move - the success net's direct grasp (points), by the attempt's index in its pile:")
    print("| training seed | attempt | states | after a move - success net |")
    print("|---:|---:|---:|---:|")
    for folder in folders:
        s = dict(np.load(os.path.join(folder, "success", "gate_states.npz")))
        gain = s["moved_success"].astype(np.float64) - s["direct_success"].astype(np.float64)
        for k in np.unique(s["attempt"]):
            sel = s["attempt"] == k
            if sel.sum() < 2:
                continue
            mean, se = _mean_se(gain[sel])
            print(f"| {training_seed(folder)} | {int(k)} | {int(sel.sum())} | {mean:+.1f} +- {se:.1f} |")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("dirs", nargs="+", help="a training's folder with q/ and success/")
    args = p.parse_args(argv)
    for d in args.dirs:
        for planner in ("q", "success"):
            if not os.path.isfile(os.path.join(d, planner, "gate.json")):
                p.error(f"{d} has no {planner}/gate.json: each DIR needs q/ and success/ (see the module's docstring)")
    pays = benchmark(args.dirs)
    print(f"\nVAGS at least +5 points over its ablation on 6-10 objects on every seed, one planner on both sides: "
          f"{'yes' if pays else 'no'}")
    tables(args.dirs)
    paired_states(args.dirs)
    by_attempt(args.dirs)
    return 0


if __name__ == "__main__":
    sys.exit(main())
