#!/usr/bin/env python3
"""What a move is worth, state by state, from ``bench/viewpoint_states.py --rows``.

    python bench/viewpoint_rows.py bench/results/viewpoints/default/controls/vp/states_6-10.npz

Reads the per-state outcomes of every branch (the .npz) and the run's gate calibration (the
.json beside it, same stem) and prints two Markdown tables:

1. Paired comparisons on the same states: each close-view branch against the direct grasp and
   against each other (success of each, difference, and the discordant pairs: states where
   only the first succeeds / only the second).
2. Moves ranked by the success net's calibrated p_direct: moving the lowest fraction q of
   states (q = 0 .. 0.4), the success of the whole set when those states take VANet's
   viewpoint, GDNet's own grasp cell as the viewpoint, or a second global capture (no move),
   and the success a move adds per moved state.

Only live states count (objects left, no physics error).
"""
from __future__ import annotations

import argparse
import math
import json
import os
import sys

import numpy as np

PAIRS = (("view_gdnet", "direct"), ("grasp_gdnet", "direct"), ("relook_direct", "direct"),
         ("grasp_gdnet", "view_gdnet"), ("random_gdnet", "view_gdnet"), ("view_gdnet", "relook_direct"))
QUANTILES = (0.0, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.4)


def load(path: str):
    """-> (rows: dict of (N,) arrays over live states, calibration (3,) list)."""
    rows = dict(np.load(path))
    live = rows.pop("live").astype(bool)
    with open(os.path.splitext(path)[0] + ".json") as f:
        calibration = json.load(f)["calibration"]
    return {k: v[live] for k, v in rows.items()}, calibration


def sign_test_p(only_first: int, only_second: int) -> float:
    """Exact two-sided McNemar (sign) test on the discordant pairs: the chance of a split at least
    this uneven if either branch were as likely to be the one that succeeds; 1.0 with no pair."""
    n, k = only_first + only_second, min(only_first, only_second)
    if n == 0:
        return 1.0
    tail = sum(math.comb(n, i) for i in range(k + 1))
    return min(1.0, 2 * tail / 2 ** n)


def paired_table(rows: dict) -> str:
    lines = ["| first | second | first % | second % | difference | only first | only second | p (sign test) |",
             "|---|---|---:|---:|---:|---:|---:|---:|"]
    for a, b in PAIRS:
        if a not in rows or b not in rows:
            continue
        x, y = rows[a].astype(bool), rows[b].astype(bool)
        only_x, only_y = int((x & ~y).sum()), int((~x & y).sum())
        lines.append(f"| {a} | {b} | {100 * x.mean():.1f} | {100 * y.mean():.1f} | {100 * (x.mean() - y.mean()):+.1f} "
                     f"| {only_x} | {only_y} | {sign_test_p(only_x, only_y):.3g} |")
    return "\n".join(lines)


def ranked_moves_table(rows: dict, calibration) -> str:
    p = rows["p_direct"] - calibration[0]
    direct = rows["direct"].astype(float)
    lines = ["| moved share | p_direct below | VANet's view % | grasp cell view % | second look % | added per move (VANet) |",
             "|---:|---:|---:|---:|---:|---:|"]
    for q in QUANTILES:
        move = p < np.quantile(p, q) if q > 0 else np.zeros_like(p, bool)
        s = {b: np.where(move, rows[b].astype(float), direct).mean()
             for b in ("view_gdnet", "grasp_gdnet", "relook_direct")}
        added = (rows["view_gdnet"][move].astype(float) - direct[move]).mean() if move.any() else float("nan")
        thr = f"{np.quantile(p, q):.3f}" if q > 0 else "-"
        lines.append(f"| {move.mean():.2f} | {thr} | {100 * s['view_gdnet']:.1f} | {100 * s['grasp_gdnet']:.1f} "
                     f"| {100 * s['relook_direct']:.1f} | {added:+.3f} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("rows", nargs="+", help=".npz files written by bench/viewpoint_states.py --rows")
    args = ap.parse_args(argv)
    for path in args.rows:
        rows, calibration = load(path)
        print(f"## {path}: {rows['direct'].shape[0]} live states, calibration {np.round(calibration, 3).tolist()}\n")
        print(paired_table(rows) + "\n")
        print(ranked_moves_table(rows, calibration) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
