#!/usr/bin/env python3
"""What ``vags.max_motion_number`` does to saved "rate" gate tables, by arithmetic on the tables
alone (no simulation): for each RUN/gate.json, the bins its gate moves in and the motion number
and success its table predicts, without a cap and under each cap given.

    python bench/gate_cap.py --caps 1.3,1.35 $(find bench/results -name gate.json)

The table's predictions are on its own states (fresh piles, GDNet's first attempts); the
benchmark's motion number ran 0.02-0.05 above them (bench/RESULTS.md, "twentieth look").
"""
from __future__ import annotations

import argparse
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from vags_jax.policies import rate_gate  # noqa: E402


def table_of(path: str) -> rate_gate.GateTable:
    """A gate.json file -> its GateTable."""
    with open(path) as f:
        return rate_gate.from_dict(json.load(f))


def rows(paths, caps) -> list[dict]:
    """One dict per table: its path, and per cap (0: none) the ``moves_summary``."""
    out = []
    for path in paths:
        t = table_of(path)
        out.append({"path": path, **{cap: rate_gate.moves_summary(rate_gate.capped(t, cap), cap) for cap in (0.0, *caps)}})
    return out


def markdown(table_rows, caps) -> str:
    head = "| table | moves in bins | motion number | success % |" + "".join(
        f" cap {c:g}: bins | motion number | success % |" for c in caps)
    lines = [head, "|---|---|---:|---:|" + "---|---:|---:|" * len(caps)]
    for r in table_rows:
        cells = [r["path"]]
        for cap in (0.0, *caps):
            s = r[cap]
            cells += [str(s["moving_bins"]), f"{s['motion_number']:.3f}", f"{100 * s['success']:.1f}"]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python bench/gate_cap.py", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("tables", nargs="+", help="RUN/gate.json files")
    p.add_argument("--caps", default="1.3,1.35", help="comma-separated motion-number caps (default: 1.3,1.35)")
    args = p.parse_args(argv)
    try:
        caps = [float(c) for c in args.caps.split(",") if c]
    except ValueError:
        p.error(f"--caps takes comma-separated numbers, got {args.caps!r}")
    if any(not 1.0 <= c <= 10.0 for c in caps):
        p.error(f"--caps: each cap is a motion number in [1, 10], got {args.caps!r}")
    print(markdown(rows(args.tables, caps), caps))
    return 0


if __name__ == "__main__":
    sys.exit(main())
