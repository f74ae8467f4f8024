"""How well each success estimate of GDNet's grasp ranks the direct grasp's outcome, and what the
"rate" gate's table would do binned on it, from the states a table was measured on
(RUN/gate_states.npz; ``python -m vags_jax.stages.gate_measure`` records every estimate there).

    python bench/gate_estimates.py runs/gpu                        # RUN/gate_states.npz, RUN/gate.json's bins
    python bench/gate_estimates.py runs/gpu --json OUT.json        # also the figures as JSON

Per column (``p_<estimate>`` for each ``vags.gate_estimate``, and for comparison only ``p_best``,
the success net's largest value anywhere, and ``q_direct``, GDNet's Q at its grasp):

* AUROC of the direct grasp's success, and of the grasp after a move;
* the lowest eighth of the states by that column: direct and after-move success there, and the
  success a move adds per state measured (both branches ran from every state, so this is paired);
* the table ``rate_gate.fit`` makes of it (the table's own bins): picks per hour, the bins it
  moves, and the motion number and success it predicts.

``pick`` is the ``vags.gate_estimate`` whose table predicts the most picks per hour (the gate's own
objective; the same states fit and score the table, as the pipeline's GDNet pick does).
"""
from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from vags_jax.config import VAGS_GATE_ESTIMATES  # noqa: E402
from vags_jax.policies import rate_gate  # noqa: E402

STATES_FILE = "gate_states.npz"


def auroc(score, positive) -> float:
    """The probability that a random positive scores above a random negative (ties count half)."""
    score, positive = np.asarray(score, np.float64), np.asarray(positive, bool)
    n1, n0 = int(positive.sum()), int((~positive).sum())
    if n1 == 0 or n0 == 0:
        return float("nan")
    _, inverse, counts = np.unique(score, return_inverse=True, return_counts=True)
    first = np.cumsum(counts) - counts + 1  # the rank of each distinct value's first copy
    ranks = (first + (counts - 1) / 2.0)[inverse]  # tied scores share their mean rank
    return float((ranks[positive].sum() - n1 * (n1 + 1) / 2) / (n1 * n0))


def columns(states: dict) -> list:
    """The estimate columns the states hold: ``p_<estimate>`` (or ``p_direct`` alone in states
    measured before the others were recorded, as ``p_grasp``), then ``p_best`` and ``q_direct``."""
    got = [f"p_{e}" for e in VAGS_GATE_ESTIMATES if f"p_{e}" in states]
    return (got or ["p_direct"]) + [k for k in ("p_best", "q_direct") if k in states]


def figures(states: dict, column: str, bins: int) -> dict:
    """The figures of one estimate column over the states (N,) (see the module's docstring)."""
    p = np.asarray(states[column], np.float64)
    d = np.asarray(states["direct_success"], np.float64)
    m = np.asarray(states["moved_success"], np.float64)
    low = np.argsort(p, kind="mergesort")[: max(1, p.size // 8)]
    table = rate_gate.fit(p, d, states["direct_seconds"], m, states["moved_seconds"], bins)
    plays = rate_gate.moves_summary(table)
    return {"auroc_direct": round(auroc(p, d > 0), 4), "auroc_moved": round(auroc(p, m > 0), 4),
            "lowest_eighth": {"states": int(low.size), "direct": round(float(d[low].mean()), 4),
                              "moved": round(float(m[low].mean()), 4),
                              "gain_per_state": round(float((m[low] - d[low]).sum() / p.size), 4)},
            "picks_per_hour": round(3600 * table.rate, 1), "moving_bins": plays["moving_bins"],
            "bins": plays["bins"], "motion_number": plays["motion_number"], "success": plays["success"]}


def report(states: dict, bins: int) -> dict:
    """{"states", "direct", "moved", "columns": {column: figures}, "pick"} for the states."""
    cols = {c: figures(states, c, bins) for c in columns(states)}
    options = {c: f for c, f in cols.items() if c.startswith("p_") and c[2:] in VAGS_GATE_ESTIMATES}
    pick = max(options, key=lambda c: options[c]["picks_per_hour"])[2:] if options else "grasp"
    return {"states": int(np.asarray(states["direct_success"]).size),
            "direct": round(float(np.mean(states["direct_success"])), 4),
            "moved": round(float(np.mean(states["moved_success"])), 4), "bins": bins, "columns": cols, "pick": pick}


def print_report(rep: dict) -> None:
    """``report``'s figures as a Markdown table, one row per column, and its pick."""
    print(f"{rep['states']} states: direct {100 * rep['direct']:.1f} %, after a move {100 * rep['moved']:.1f} %; "
          f"{rep['bins']} bins")
    print("| column | AUROC direct | AUROC moved | lowest 8th: direct % | after a move % | gain per state (points) "
          "| picks/h | moving bins | motion number | success % |")
    print("|---|---:|---:|---:|---:|---:|---:|---|---:|---:|")
    for c, f in rep["columns"].items():
        lo = f["lowest_eighth"]
        print(f"| {c} | {f['auroc_direct']:.3f} | {f['auroc_moved']:.3f} | {100 * lo['direct']:.1f} | "
              f"{100 * lo['moved']:.1f} | {100 * lo['gain_per_state']:+.2f} | {f['picks_per_hour']:.0f} | "
              f"{f['moving_bins']} | {rate_gate.motion_number_text(f['motion_number'])} | {100 * f['success']:.1f} |")
    print(f"pick: {rep['pick']} (the vags.gate_estimate whose table predicts the most picks per hour)")


def load(path: str):
    """A run directory or a gate_states.npz -> (states, bins of the gate.json beside it or None)."""
    npz = os.path.join(path, STATES_FILE) if os.path.isdir(path) else path
    if not os.path.isfile(npz):
        raise SystemExit(f"gate_estimates: no {npz}: measure the table first "
                         f"(python -m vags_jax.stages.gate_measure --run RUN)")
    with np.load(npz) as f:
        states = {k: f[k] for k in f.files}
    d = rate_gate.read(os.path.dirname(npz))
    return states, (len(d["states"]) if d else None)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("path", help="a run directory (RUN/gate_states.npz) or a gate_states.npz")
    ap.add_argument("--bins", type=int, default=None, help="quantile bins (default: its gate.json's, else 8)")
    ap.add_argument("--json", default=None, help="also write the figures here")
    args = ap.parse_args(argv)
    states, table_bins = load(args.path)
    rep = report(states, args.bins or table_bins or 8)
    print_report(rep)
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"path": args.path, **rep}, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
