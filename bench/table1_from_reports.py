#!/usr/bin/env python3
"""Table 1 and Fig. 7 from ``eval.py`` reports written one method at a time (as
``bench/table1_h100.sh`` does), without playing anything again.

    python bench/table1_from_reports.py bench/results/table1/default/eval_*.json \
        --out bench/results/table1/default/table1.json --plot bench/results/table1/default/fig7.png

The reports must share seed, groups and rounds, and their scene digests must agree.
``--ignore-digests`` skips the digest check (only the digest): for reports written before the
digest was taken of the scene draws, when it hashed the settled poses, which the GPU physics
does not reproduce from one process to the next.  The JSON records that the check was skipped.
"""
from __future__ import annotations

import argparse
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def main(argv=None) -> int:
    from vags_jax.benchmark import compare as CMP

    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("reports", nargs="+", help="eval.py report .json files, one per method")
    p.add_argument("--out", default=None, help="Table 1 as JSON (+ CSV beside it)")
    p.add_argument("--plot", default=None, help="Fig. 7 as PNG (needs matplotlib)")
    p.add_argument("--ignore-digests", action="store_true")
    args = p.parse_args(argv)
    loaded = {}
    for path in args.reports:
        with open(path) as f:
            rep = json.load(f)
        loaded[rep.get("policy") or os.path.basename(path)] = rep
    first = next(iter(loaded.values()))
    meta = {"seed": first.get("seed"), "groups": first.get("groups"), "rounds": first.get("rounds"),
            "scene_digests_checked": not args.ignore_digests, "reports": [os.path.basename(r) for r in args.reports]}
    try:
        CMP.publish(loaded, args.out, args.plot, meta, lambda m: print(m, file=sys.stderr),
                    digests=not args.ignore_digests)
    except ValueError as e:
        print(f"table1_from_reports: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
