#!/usr/bin/env python3
"""What ``vags.max_motion_number`` does to saved "rate" gate tables, by arithmetic on the tables
alone (no simulation): for each RUN/gate.json, the bins its gate moves in and the motion number
and success its table predicts, without a cap and under each cap given.

    python bench/gate_cap.py --caps 1.3,1.35 $(find bench/results -name gate.json)
    python bench/gate_cap.py --bins 16 --caps 1.3 RUN/gate.json   # the same states in 16 bins
    python bench/gate_cap.py --min-z 2 --caps 1.3 RUN/gate.json   # with vags.gate_min_z=2 first

``--bins K`` fits each table again over K quantile bins from the states it was measured on
(``gate_states.npz`` beside it; ``gate_measure --refit`` without writing anything).  Where those
states are there, each setting also gets the success on the states with 6 objects or more and
the share of the one-object states it moves, and a cap takes the moving bins by success gain
and splits the next one, as ``eval.py`` does (``rate_gate.split_capped``, ``vags.cap_split``; the split adds a bin, so the
bin indices after it shift by one); ``--whole-bins`` drops whole bins instead.  ``--min-z Z``
drops first the moves within Z standard errors of 0, as ``eval.py --set vags.gate_min_z=Z``
does (``rate_gate.significant``; tables that record their errors only).

The table's predictions are on its own states (fresh piles, GDNet's first attempts); the
benchmark's motion number ran 0.028 above them on average, up to 0.071, over 30 evaluations
(bench/RESULTS.md, "twenty-seventh look"), and 0.055 (0.012-0.097) over 15 since the benchmark
drops spilled piles again ("forty-second and forty-third looks").
"""
from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from vags_jax.policies import rate_gate  # noqa: E402
from vags_jax.stages import gate_measure  # noqa: E402


def table_of(path: str) -> rate_gate.GateTable:
    """A gate.json file -> its GateTable."""
    with open(path) as f:
        return rate_gate.from_dict(json.load(f))


def on_states(table: rate_gate.GateTable, states: dict) -> dict:
    """Where ``table`` moves on the measured states (N,): success on those with 6+ objects, and
    the share of the one-object states moved (nan where there are none)."""
    moves = rate_gate.moves_at(table, states["p_direct"])
    success = np.where(moves, states["moved_success"], states["direct_success"])
    objects = states["objects"]
    mean = lambda x: float(np.mean(x)) if x.size else float("nan")  # noqa: E731
    return {"success_6plus": mean(success[objects >= 6]), "moved_at_1": mean(moves[objects == 1])}


def rows(paths, caps, bins: int = 0, split: bool = True, min_z: float = 0.0) -> list[dict]:
    """One dict per table: its path, and per cap (0: none) the ``moves_summary``, with
    ``on_states`` where the measured states are beside it; ``bins`` > 0 fits each table again
    over that many bins of those states first (ValueError where they are missing); ``split``:
    caps split a bin where the states allow (``rate_gate.split_capped``), else drop whole bins;
    ``min_z`` > 0: the moves within that many standard errors of 0 are dropped before any cap
    (``rate_gate.significant``; ValueError for a table without errors)."""
    out = []
    for path in paths:
        if bins:
            t, _, states = gate_measure.refit(os.path.dirname(path), bins)
        else:
            t, states = table_of(path), rate_gate.read_states(os.path.dirname(path))
        t = rate_gate.significant(t, min_z)
        row = {"path": path}
        split_here = split and rate_gate.states_match(t, states)
        for cap in (0.0, *caps):
            c = rate_gate.split_capped(t, states, cap) if split_here else rate_gate.capped(t, cap)
            row[cap] = {**rate_gate.moves_summary(c, cap, min_z), **(on_states(c, states) if states else {})}
        out.append(row)
    return out


def markdown(table_rows, caps) -> str:
    extra = any("success_6plus" in r[0.0] for r in table_rows)
    per = " bins | motion number | success % |" + (" 6+ objects % | moved at 1 object % |" if extra else "")
    head = "| table | moves in" + per + "".join(f" cap {c:g}:" + per for c in caps)
    lines = [head, "|---|" + ("---|---:|---:|" + ("---:|---:|" if extra else "")) * (1 + len(caps))]
    for r in table_rows:
        cells = [r["path"]]
        for cap in (0.0, *caps):
            s = r[cap]
            cells += [str(s["moving_bins"]), rate_gate.motion_number_text(s["motion_number"]),
                      f"{100 * s['success']:.1f}"]
            if extra:
                cells += [f"{100 * s[k]:.1f}" if k in s else "" for k in ("success_6plus", "moved_at_1")]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python bench/gate_cap.py", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("tables", nargs="+", help="RUN/gate.json files")
    p.add_argument("--caps", default="1.3,1.35", help="comma-separated motion-number caps (default: 1.3,1.35)")
    p.add_argument("--bins", type=int, default=0,
                   help="fit each table again over this many quantile bins of its measured states (gate_states.npz "
                        "beside it) first; 0: the table as saved")
    p.add_argument("--min-z", type=float, default=0.0,
                   help="drop first the moves within this many standard errors of 0 (vags.gate_min_z; 0: none)")
    p.add_argument("--whole-bins", action="store_true",
                   help="caps drop whole bins even where the measured states would split one (vags.cap_split=false)")
    args = p.parse_args(argv)
    try:
        caps = [float(c) for c in args.caps.split(",") if c]
    except ValueError:
        p.error(f"--caps takes comma-separated numbers, got {args.caps!r}")
    if any(not 1.0 <= c <= 10.0 for c in caps):
        p.error(f"--caps: each cap is a motion number in [1, 10], got {args.caps!r}")
    if not 0.0 <= args.min_z <= 10.0:
        p.error(f"--min-z takes a number of standard errors in [0, 10], got {args.min_z:g}")
    if args.bins < 0:
        p.error(f"--bins takes a number of bins (0: the table as saved), got {args.bins}")
    try:
        print(markdown(rows(args.tables, caps, args.bins, split=not args.whole_bins, min_z=args.min_z), caps))
    except ValueError as e:
        print(f"gate_cap.py: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
