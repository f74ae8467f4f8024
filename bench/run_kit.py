#!/usr/bin/env python3
"""Copies the part of a trained run that ``eval.py`` and ``predict`` read into a small folder: its
config, gate table (with the states it was fit on), summary, GG-CNN if any, and of stages 2-3
only the saved networks (``RUN/stage<N>/networks``, no replay, optimizer or worlds) at the steps
the gate table names (else each stage's latest).  The folder is a run directory ``eval.py --run``
accepts, small enough to bring back from a device machine and carry to a later one, so a
benchmark or a timing can be repeated on the same networks without training them again.

    python bench/run_kit.py --run runs/vags --out kits/vags          # prints what it kept, in MB

Exits 1 with one line when the run has no stage-2 or stage-3 networks (nothing to evaluate with
VAGS) or the output folder exists.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from vags_jax.stages import checkpoint, rundir  # noqa: E402
from vags_jax.policies import rate_gate  # noqa: E402

RUN_FILES = (checkpoint.CONFIG_FILE, rate_gate.GATE_FILE, rate_gate.STATES_FILE, "summary.json", "timings.jsonl")
STAGES = ("stage2", "stage3")


def steps_to_keep(run_dir: str) -> dict:
    """{stage: sorted steps} of the networks to copy: those RUN/gate.json names ("networks",
    "gdnet", "close_gdnet", e.g. "stage2 step 80") and each stage's latest (what ``eval.py``
    plays by default); a stage without saved networks is left out."""
    saved = {s: checkpoint.checkpoint_steps(rundir.networks_dir(run_dir, s)) for s in STAGES}
    keep = {s: {steps[-1]} for s, steps in saved.items() if steps}
    gate = rate_gate.read(run_dir) or {}
    for key in ("networks", "gdnet", "close_gdnet"):
        m = re.fullmatch(r"(stage[23]) step (\d+)", str(gate.get(key, "")))
        if m and int(m.group(2)) in saved.get(m.group(1), []):
            keep.setdefault(m.group(1), set()).add(int(m.group(2)))
    return {s: sorted(v) for s, v in keep.items()}


def folder_mb(path: str) -> float:
    return sum(os.path.getsize(os.path.join(d, f)) for d, _, files in os.walk(path) for f in files) / 2**20


def make_kit(run_dir: str, out: str) -> dict:
    """Writes the kit of ``run_dir`` to ``out`` (which must not exist) -> {"steps": steps_to_keep,
    "mb": its size in MiB}."""
    if os.path.exists(out):
        raise ValueError(f"{out} exists: give a new folder for the kit")
    keep = steps_to_keep(run_dir)
    if not keep:
        raise ValueError(f"run {run_dir} has no stage-2 or stage-3 networks to keep: train stages 2-3 first")
    os.makedirs(out)
    for name in RUN_FILES:
        if os.path.isfile(os.path.join(run_dir, name)):
            shutil.copy2(os.path.join(run_dir, name), out)
    for stage, steps in keep.items():
        src = os.path.join(rundir.networks_dir(run_dir, stage), checkpoint.CHECKPOINT_DIR)
        dst = os.path.join(rundir.networks_dir(out, stage), checkpoint.CHECKPOINT_DIR)
        for step in steps:
            shutil.copytree(os.path.join(src, str(step)), os.path.join(dst, str(step)))
    gg = os.path.join(run_dir, "ggcnn")
    if os.path.isdir(gg):
        shutil.copytree(gg, os.path.join(out, "ggcnn"))
    return {"steps": keep, "mb": round(folder_mb(out), 2)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--run", required=True, help="a run directory written by train.py")
    ap.add_argument("--out", required=True, help="the kit's folder (must not exist)")
    args = ap.parse_args(argv)
    try:
        got = make_kit(args.run, args.out)
    except (ValueError, OSError) as e:
        print(f"run_kit: {e}", file=sys.stderr)
        return 1
    print(json.dumps({"run": args.run, "out": args.out, **got}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
