"""Are two run directories the same training, bit for bit?

    python bench/compare_runs.py RUN_A RUN_B

Compares every array of every checkpoint step under each run's checkpoint directories (stage 1's,
GG-CNN's, stages 2-3's and their ``networks/``), the stages' ``metrics.jsonl`` without their
wall-clock seconds, and ``gate.json`` without its wall clock and device.  Prints what it compared;
exits 1 naming the first difference.  Used to show that a change leaves training unchanged
(bench/RESULTS.md).
"""
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from vags_jax.stages import checkpoint  # noqa: E402

VOLATILE = ("wall_s", "device", "time")


class Difference(Exception):
    """The runs differ (the message says where)."""


def _require(same: bool, where: str) -> None:
    # An exception, not ``assert``: python -O must not turn a difference into "equal".
    if not same:
        raise Difference(where)


def checkpoint_dirs(run: str) -> list[str]:
    """Sub-directories of ``run`` (relative, sorted) that hold a ``checkpoints/`` folder."""
    return sorted(os.path.relpath(root, run) for root, _, _ in os.walk(run)
                  if os.path.isdir(os.path.join(root, "checkpoints")))


def _rows(path: str) -> list[dict]:
    with open(path) as f:
        rows = [json.loads(line) for line in f]
    return [{k: v for k, v in r.items() if k not in VOLATILE} for r in rows]


def _json(path: str) -> dict:
    with open(path) as f:
        return {k: v for k, v in json.load(f).items() if k not in VOLATILE}


def compare(a: str, b: str) -> list[str]:
    """-> lines saying what was compared; raises ``Difference`` at the first difference."""
    dirs = checkpoint_dirs(a)
    _require(dirs == checkpoint_dirs(b), f"checkpoint directories differ: {dirs} vs {checkpoint_dirs(b)}")
    n_arrays, out = 0, []
    for rel in dirs:
        steps = checkpoint.checkpoint_steps(os.path.join(a, rel))
        _require(steps == checkpoint.checkpoint_steps(os.path.join(b, rel)), f"{rel}: checkpoint steps differ")
        for step in steps:
            sa, _ = checkpoint.read(os.path.join(a, rel), step)
            sb, _ = checkpoint.read(os.path.join(b, rel), step)
            _require(sa.keys() == sb.keys(), f"{rel} step {step}: parts differ")
            for part, leaves in sa.items():
                _require(leaves.keys() == sb[part].keys(), f"{rel} step {step} {part}: leaves differ")
                for k, x in leaves.items():
                    y = sb[part][k]
                    _require(x.dtype == y.dtype and np.array_equal(x, y, equal_nan=True),
                             f"{rel} step {step} {part} leaf {k} differs")
                    n_arrays += 1
        out.append(f"{rel}: steps {steps} equal")
    for name in ("metrics.jsonl", "stage2/metrics.jsonl", "stage3/metrics.jsonl", "gate.json"):
        pa, pb = os.path.join(a, name), os.path.join(b, name)
        _require(os.path.exists(pa) == os.path.exists(pb), f"{name} is in one run only")
        if os.path.exists(pa):
            read = _json if name.endswith(".json") else _rows
            _require(read(pa) == read(pb), f"{name} differs")
            out.append(f"{name} equal")
    out.append(f"{n_arrays} arrays equal")
    return out


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 2 or not all(os.path.isdir(p) for p in argv):
        print("usage: python bench/compare_runs.py RUN_A RUN_B (two run directories)", file=sys.stderr)
        return 2
    try:
        lines = compare(*argv)
    except Difference as e:
        print(f"different: {e}")
        return 1
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
