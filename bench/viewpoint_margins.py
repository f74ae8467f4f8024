#!/usr/bin/env python3
"""VAGS's margin over its ablation against the ablation's own success, across evaluations.

    python bench/viewpoint_margins.py \\
        $(find bench/results/viewpoints -type d -name 'seed1*' -exec dirname {} \\; | sort -u)

For each folder holding ``seed<S>/eval_vags.json`` and ``seed<S>/eval_vags-no-viewpoint.json``
(or ``.json.gz``), one row: the seeds, the ablation's and VAGS's mean grasp success, VAGS's
mean motion number, and VAGS minus the ablation on groups 6-10 (pooled success) per seed.  Then
the correlation of that margin with the ablation's success over every (folder, seed).  Folders
may share a training (other GDNet picks or settings on the same networks): they are
evaluations, not independent trainings.
"""
from __future__ import annotations

import argparse
import glob
import os
import re
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from viewpoint_goals import pooled, read_report  # noqa: E402


def folder_rows(folder: str) -> list[dict]:
    """Per seed with both reports: the ablation's and VAGS's success, VAGS's motion number and
    the 6-10 margin (fractions)."""
    out = []
    for d in sorted(glob.glob(os.path.join(folder, "seed*"))):
        if not re.fullmatch(r"seed\d+", os.path.basename(d)):
            continue
        va = read_report(os.path.join(d, "eval_vags.json"))
        nv = read_report(os.path.join(d, "eval_vags-no-viewpoint.json"))
        if va is None or nv is None:
            continue
        out.append({"seed": int(os.path.basename(d)[4:]), "ablation": nv["overall"]["grasp_success_rate"],
                    "vags": va["overall"]["grasp_success_rate"], "motion_number": va["overall"]["motion_number"],
                    "margin_6_10": pooled(va, 6, 10)[0] - pooled(nv, 6, 10)[0]})
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python bench/viewpoint_margins.py", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("folders", nargs="+", help="folders with seed<S>/eval_vags*.json[.gz]")
    args = p.parse_args(argv)
    print("| folder | seeds | ablation % | VAGS % | motion number | 6-10: VAGS − ablation, per seed |")
    print("|---|---:|---:|---:|---:|---|")
    pairs = []
    for folder in args.folders:
        rows = folder_rows(folder)
        if not rows:
            continue
        mean = lambda k: float(np.mean([r[k] for r in rows]))  # noqa: E731
        margins = ", ".join(f"{100 * r['margin_6_10']:+.1f}" for r in rows)
        print(f"| {folder} | {len(rows)} | {100 * mean('ablation'):.1f} | {100 * mean('vags'):.1f} | "
              f"{mean('motion_number'):.3f} | {margins} |")
        pairs += [(r["ablation"], r["margin_6_10"]) for r in rows]
    if len(pairs) < 3:
        print("fewer than 3 (folder, seed) pairs: no correlation", file=sys.stderr)
        return 0 if pairs else 2
    a, m = np.asarray(pairs).T
    slope = np.polyfit(a, m, 1)[0]
    print(f"\n{len(pairs)} (folder, seed) pairs: correlation of the 6-10 margin with the ablation's success "
          f"{np.corrcoef(a, m)[0, 1]:+.2f}; slope {slope:+.2f} points of margin per point of ablation success")
    return 0


if __name__ == "__main__":
    sys.exit(main())
