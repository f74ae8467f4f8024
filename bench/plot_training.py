#!/usr/bin/env python3
"""Plot grasp success vs grasp attempts (and vs wall time) for training runs (paper Figure 9).

    python bench/plot_training.py runs/daes runs/no_daes --labels DAES "no DAES" --out bench/fig9.png

Reads each run's metrics.jsonl (or metrics.jsonl.gz; one row per stage-1 iteration: success_rate over the batch of worlds,
grasp_attempts, wall_s) and draws the success rate averaged over a sliding window of attempts.
Needs matplotlib (not a dependency of the package: pip install matplotlib).  Also prints, per
run, the success rate of the last window and the attempts / wall time at which the windowed
success first reached each of the thresholds given by --thresholds.
"""
from __future__ import annotations

import argparse
import gzip
import json
import os
import sys

import numpy as np


def load(run_dir):
    """A run's stage-1 rows -> (attempts, success, wall seconds), each (iterations,); reads
    metrics.jsonl, or metrics.jsonl.gz where it was committed gzipped."""
    path = os.path.join(run_dir, "metrics.jsonl")
    opener = open if os.path.exists(path) or not os.path.exists(path + ".gz") else gzip.open
    with opener(path if opener is open else path + ".gz", "rt") as f:
        rows = [r for r in map(json.loads, f) if r.get("stage", "stage1") == "stage1"]
    rows.sort(key=lambda r: r["iteration"])
    att = np.array([r["grasp_attempts"] for r in rows], float)
    succ = np.array([r["success_rate"] for r in rows], float)
    wall = np.array([r["wall_s"] for r in rows], float)
    return att, succ, wall


def windowed(att, succ, window_attempts):
    """Mean success over the last `window_attempts` attempts at each iteration (attempt-weighted)."""
    per_it = np.diff(np.concatenate([[0.0], att]))
    wins = succ * per_it
    cw, ca = np.cumsum(wins), np.cumsum(per_it)
    out = np.empty_like(succ)
    for i in range(len(att)):
        j = np.searchsorted(ca, ca[i] - window_attempts, side="right")
        w0 = cw[j - 1] if j > 0 else 0.0
        a0 = ca[j - 1] if j > 0 else 0.0
        out[i] = (cw[i] - w0) / max(ca[i] - a0, 1e-9)
    return out


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("runs", nargs="+")
    p.add_argument("--labels", nargs="*")
    p.add_argument("--window", type=float, default=2000, help="sliding window, grasp attempts")
    p.add_argument("--thresholds", nargs="*", type=float, default=[0.6, 0.7])
    p.add_argument("--out", default="training_curve.png")
    args = p.parse_args(argv)
    labels = args.labels or [os.path.basename(r.rstrip("/")) for r in args.runs]
    if len(labels) != len(args.runs):
        raise SystemExit("error: give one --labels entry per run")
    curves = []
    for run, label in zip(args.runs, labels):
        att, succ, wall = load(run)
        w = windowed(att, succ, args.window)
        curves.append((label, att, w, wall))
        first = []
        for th in args.thresholds:
            k = np.flatnonzero(w >= th)
            first.append(f"{th:.0%}: " + (f"{int(att[k[0]])} attempts / {wall[k[0]] / 60:.1f} min" if k.size else "never"))
        print(f"{label}: {int(att[-1])} attempts in {wall[-1] / 60:.1f} min; success over the last "
              f"{int(args.window)} attempts {w[-1]:.1%}; first reached " + "; ".join(first))
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed: pip install matplotlib to draw the figure", file=sys.stderr)
        return 1
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for label, att, w, wall in curves:
        axes[0].plot(att, w, label=label)
        axes[1].plot(wall / 60, w, label=label)
    axes[0].set_xlabel("grasp attempts (all worlds)")
    axes[1].set_xlabel("wall-clock training time (min)")
    for ax in axes:
        ax.set_ylabel(f"grasp success (last {int(args.window)} attempts)")
        ax.set_ylim(0, 1)
        ax.grid(alpha=0.3)
        ax.legend()
    fig.suptitle("GDNet (stage 1), 1-5 objects: grasp success during training")
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
