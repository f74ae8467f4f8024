"""The grasp after a camera move under two settings, paired on the same states, from two
measurements of the "rate" gate's table on one run (``python -m vags_jax.stages.gate_measure``).

    python -m vags_jax.stages.gate_measure --run runs/gpu                         # A: the run's own table
    python -m vags_jax.stages.gate_measure --run runs/gpu --out runs/gpu/success --close-score success  # B
    python bench/paired_tables.py runs/gpu runs/gpu/success --names q success [--json OUT.json]

Why: both measurements start from the same fresh piles (the same seed) and the piles follow the
direct grasp, so they visit the same states up to the physics' nondeterminism, and each state
runs the grasp after a move under both settings; compared on the same states (paired), the
spread between piles drops out.  On the GPU the piles do diverge: on two trainings the matched
states' objects agreed on 54-59 % (bench/RESULTS.md, "twenty-fifth look").  There the two are
samples of one distribution of states, and the standard error is about the unpaired one.

Each DIR holds ``gate.json`` (``rate_gate.save``) and ``gate_states.npz`` (``gate_measure.save_all``):
(N,) arrays per live state, of which ``world``, ``attempt``, ``p_direct``, ``objects``,
``direct_success`` and ``moved_success`` are read.  The rows are joined on (world, attempt);
as a check that the matched states are the same ones, the share of them whose ``objects`` and
whose ``direct_success`` agree (the direct grasps are the same computation: low agreement means
the piles diverged).  Per subset of the matched states (all; the bins of A's table that move and
those it keeps, by A's p_direct; 1-5 and 6+ objects; the bins of B's table that move, by B's
p_direct): direct success (A), success after a move in A and in B, the paired difference B - A
in points with its standard error (std of the per-state difference, ddof=1, / sqrt(n)), and the
discordant pairs (A succeeded and B failed; A failed and B succeeded).  Also each table's own
figures: picks per hour, the bins it moves, and the motion number and success it predicts
(``rate_gate.moves_summary``, from the table's bin counts).
"""
from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from gate_estimates import STATES_FILE  # noqa: E402
from gate_estimates import load as load_states  # noqa: E402

from vags_jax.policies import rate_gate  # noqa: E402

PROG = "paired_tables"
MEASURE = "python -m vags_jax.stages.gate_measure"
REQUIRED = ("world", "attempt", "p_direct", "objects", "direct_success", "moved_success")
DIVERGED = 0.9  # a warning below this share of matched states whose objects agree


def load_dir(path: str) -> tuple[dict, dict]:
    """DIR -> (its gate_states.npz as (N,) arrays, its gate.json as written); SystemExit naming
    the missing file or columns and the command that makes them."""
    for name in (rate_gate.GATE_FILE, STATES_FILE):
        if not os.path.isfile(os.path.join(path, name)):
            raise SystemExit(f"{PROG}: no {os.path.join(path, name)}: measure the table with {MEASURE} --run RUN "
                             f"--out {path} (or --run {path} for a run's own table)")
    states, _ = load_states(path)
    missing = [k for k in REQUIRED if k not in states]
    if missing:
        raise SystemExit(f"{PROG}: {os.path.join(path, STATES_FILE)} lacks {missing}: measure it again with "
                         f"{MEASURE} --run RUN --out {path}")
    return states, rate_gate.read(path)


def keys(states: dict) -> np.ndarray:
    """(N,) int64 key of each state's (world, attempt); SystemExit where one repeats."""
    k = (np.asarray(states["world"], np.int64) << 32) | np.asarray(states["attempt"], np.int64)
    if np.unique(k).size != k.size:
        raise SystemExit(f"{PROG}: (world, attempt) repeats within one gate_states.npz: not one measurement")
    return k


def match(a: dict, b: dict) -> tuple[np.ndarray, np.ndarray]:
    """-> (ia, ib) (M,) row indices of the states in A and in B with the same (world, attempt)."""
    _, ia, ib = np.intersect1d(keys(a), keys(b), assume_unique=True, return_indices=True)
    return ia, ib


def paired(direct_a, moved_a, moved_b) -> dict:
    """Figures of one subset, (n,) success arrays of the same states (see the module's docstring)."""
    d, a, b = (np.asarray(x, np.float64) for x in (direct_a, moved_a, moved_b))
    n = int(d.size)
    diff = b - a
    pct = lambda x: round(100 * float(x.mean()), 3) if n else None  # noqa: E731
    se = round(100 * float(np.std(diff, ddof=1) / np.sqrt(n)), 3) if n > 1 else None
    return {"n": n, "direct": pct(d), "moved_a": pct(a), "moved_b": pct(b), "difference": pct(diff), "se": se,
            "a_only": int(np.sum((a > 0) & ~(b > 0))), "b_only": int(np.sum(~(a > 0) & (b > 0)))}


def table_figures(d: dict) -> dict:
    """A gate.json's own figures: picks per hour, the moving bins, the motion number and success it
    predicts (``rate_gate.moves_summary``) and the settings it was measured under."""
    table = rate_gate.from_dict(d)
    plays = rate_gate.moves_summary(table)
    meta = {k: d[k] for k in ("close_score", "estimate", "gdnet", "close_gdnet") if k in d}
    return {"picks_per_hour": round(3600 * table.rate, 1), "states": int(sum(table.states)),
            "moving_bins": plays["moving_bins"], "bins": plays["bins"], "motion_number": plays["motion_number"],
            "success": plays["success"], **meta}


def report(dir_a: str, dir_b: str, names=("A", "B")) -> dict:
    """The comparison of DIR_A and DIR_B (see the module's docstring) as a dict."""
    (sa, ga), (sb, gb) = load_dir(dir_a), load_dir(dir_b)
    ia, ib = match(sa, sb)
    if ia.size == 0:
        raise SystemExit(f"{PROG}: no state of {dir_a} matches one of {dir_b} on (world, attempt): "
                         f"measure both with the same --worlds, --steps and --seed")
    a = {k: np.asarray(sa[k])[ia] for k in REQUIRED}  # the matched rows, in the same order
    b = {k: np.asarray(sb[k])[ib] for k in REQUIRED}
    a_moves = rate_gate.moves_at(rate_gate.from_dict(ga), a["p_direct"])
    b_moves = rate_gate.moves_at(rate_gate.from_dict(gb), b["p_direct"])
    few = np.asarray(a["objects"]) <= 5
    subsets = {"all": np.ones(ia.size, bool), "a_moving": a_moves, "a_kept": ~a_moves,
               "objects_1_5": few, "objects_6_up": ~few, "b_moving": b_moves}
    labels = {"all": "all", "a_moving": f"{names[0]}'s moving bins", "a_kept": f"{names[0]}'s kept bins",
              "objects_1_5": "1-5 objects", "objects_6_up": "6+ objects", "b_moving": f"{names[1]}'s moving bins"}
    agree = lambda k: round(float(np.mean(np.asarray(a[k]) == np.asarray(b[k]))), 4)  # noqa: E731
    return {"dirs": [dir_a, dir_b], "names": list(names), "states": [int(sa["world"].size), int(sb["world"].size)],
            "matched": int(ia.size), "objects_agree": agree("objects"), "direct_agree": agree("direct_success"),
            "subsets": {k: {"label": labels[k], **paired(a["direct_success"][m], a["moved_success"][m],
                                                         b["moved_success"][m])} for k, m in subsets.items()},
            "tables": [table_figures(ga), table_figures(gb)]}


def _cell(v, fmt: str) -> str:
    return "-" if v is None else format(v, fmt)


def print_report(rep: dict) -> None:
    """``report``'s figures as Markdown: the match, one row per subset, one row per table."""
    na, nb = rep["names"]
    print(f"{na}: {rep['dirs'][0]}; {nb}: {rep['dirs'][1]}")
    print(f"states: {rep['states'][0]} in {na}, {rep['states'][1]} in {nb}, {rep['matched']} matched on "
          f"(world, attempt); objects agree on {100 * rep['objects_agree']:.1f} %, direct success on "
          f"{100 * rep['direct_agree']:.1f} %")
    if rep["objects_agree"] < DIVERGED:
        print(f"**warning**: objects agree on under {100 * DIVERGED:.0f} % of the matched states: the piles "
              f"diverged, so the pairs are not the same states")
    print()
    print(f"| states | n | direct % ({na}) | after a move % ({na}) | after a move % ({nb}) | {nb} - {na} (points) "
          f"| {na} only | {nb} only |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for s in rep["subsets"].values():
        print(f"| {s['label']} | {s['n']} | {_cell(s['direct'], '.1f')} | {_cell(s['moved_a'], '.1f')} | "
              f"{_cell(s['moved_b'], '.1f')} | {_cell(s['difference'], '+.2f')} +- {_cell(s['se'], '.2f')} | "
              f"{s['a_only']} | {s['b_only']} |")
    print()
    print("| table | close score | states | picks/h | moving bins | motion number | success % |")
    print("|---|---|---:|---:|---|---:|---:|")
    for name, t in zip(rep["names"], rep["tables"]):
        print(f"| {name} | {t.get('close_score', '-')} | {t['states']} | {t['picks_per_hour']:.0f} | "
              f"{t['moving_bins']} of {t['bins']} | {rate_gate.motion_number_text(t['motion_number'])} | "
              f"{100 * t['success']:.1f} |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python bench/paired_tables.py", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dir_a", help="a directory with gate.json and gate_states.npz (e.g. the run's)")
    ap.add_argument("dir_b", help="another, measured on the same run under another setting (gate_measure --out)")
    ap.add_argument("--names", nargs=2, default=("A", "B"), metavar=("NAME_A", "NAME_B"),
                    help="labels of A and B in the report (default: A B)")
    ap.add_argument("--json", default=None, help="also write the report here")
    args = ap.parse_args(argv)
    rep = report(args.dir_a, args.dir_b, tuple(args.names))
    print_report(rep)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rep, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
