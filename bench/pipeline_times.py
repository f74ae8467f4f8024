#!/usr/bin/env python3
"""Each pipeline's wall clock and its stages', from a device driver's results folder.

    python bench/pipeline_times.py bench/results/viewpoints/default/thirtythird_look f44="cold (empty cache)" w45 w46

DIR holds the driver's ``machine_log.txt`` (a line ``train_<RUN>[_suffix] rc=0 <N> s`` per
train.py run) and, per run, ``RUN/timings.jsonl`` as train.py wrote it.  Prints one Markdown row
per run: train.py's seconds, each stage's and the gate table's, the seconds spent loading and
compiling programs, and the compile-ahead children's outcome (``stages.precompile``).
"""
from __future__ import annotations

import json
import os
import re
import sys

STAGES = ("stage1", "stage2", "stage3", "gate")


def load_jsonl(path: str) -> list:
    with open(path) as f:
        return [json.loads(line) for line in f if line.strip()]


def wall_clocks(log_path: str) -> dict:
    """{run: seconds of its train.py} from a driver's machine log (runs that exited 0)."""
    with open(log_path) as f:
        return {m.group(1): int(m.group(2)) for m in re.finditer(r"^train_([a-z]+\d+)\S* rc=0 (\d+) s", f.read(), re.M)}


def ahead(rows: dict, key: str) -> str:
    """A compile-ahead child's outcome from timings.jsonl's rows by stage."""
    r = rows.get(key)
    if r is None:
        return "not run"
    if "compile" not in r:  # a child that failed before it reported its programs
        return f"{r['status']}, {r['wall_s']:.0f} s"
    return f"{r['status']}, {r['compile']['compiled']} compiled, {r['compile']['loaded']} loaded, {r['wall_s']:.0f} s"


def table(directory: str, runs) -> str:
    """runs: (run, label) pairs, in the table's order -> the Markdown table."""
    walls = wall_clocks(os.path.join(directory, "machine_log.txt"))
    lines = ["| run | train.py s | stage 1 s | stage 2 s | stage 3 s | gate table s | loading + compiling s "
             "(stages + table) | compile ahead: stage 2 / gate table |",
             "|---|---:|---:|---:|---:|---:|---:|---|"]
    for run, label in runs:
        name = f"{run}, {label}" if label else run
        path = os.path.join(directory, run, "timings.jsonl")
        if not os.path.exists(path):
            lines.append(f"| {name} | not run | | | | | | |")
            continue
        rows = {r["stage"]: r for r in load_jsonl(path)}
        compiling = sum(rows[s]["compile"]["seconds"] for s in STAGES if s in rows)
        lines.append(f"| {name} | {walls.get(run, '')} | "
                     + " | ".join(f"{rows[s]['wall_s']:.1f}" if s in rows else "" for s in STAGES)
                     + f" | {compiling:.1f} | {ahead(rows, 'compile_ahead')} / {ahead(rows, 'compile_ahead_gate')} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    directory, runs = argv[0], [tuple(a.split("=", 1)) if "=" in a else (a, "") for a in argv[1:]]
    if not os.path.isfile(os.path.join(directory, "machine_log.txt")):
        print(f"pipeline_times.py: {directory} has no machine_log.txt (a device driver's results folder)", file=sys.stderr)
        return 2
    print(table(directory, runs))
    return 0


if __name__ == "__main__":
    sys.exit(main())
