#!/usr/bin/env python3
"""What a viewpoint can add, on the states the run's gate table was measured on, split by the
gate's decision: every branch executed from the same states (the simulator is pure).

    python bench/gate_headroom.py --run runs/gpu --out bench/results/viewpoints/default/headroom.json

The run's own gate table (RUN/gate.json, as ``eval.py`` plays it) decides, per state, whether
VAGS grasps directly or moves the camera.  From each state, each in its own copy of the physics
(``vags_jax.stages.gate_measure`` with its diagnostic ``EXTRA_BRANCHES``):

* ``direct``: the run's direct grasp from the global view (``vags.direct_score``'s planner);
* ``moved``: the camera moves to VANet's viewpoint, the run's close-view planner grasps;
* ``random``: the same move and planner, to a uniformly random object cell (does VANet's
  choice beat chance?);
* ``oracle``: the direct planner on ground-truth top-down maps (no occlusion, no sensor noise):
  the most any viewpoint could show it, though not a ceiling for a planner that learned on the
  global view's maps (bench/RESULTS.md, "thirty-third look": GDNet grasped worse on them);
* ``planned``: no move; the success net's direct grasp on the global view (what
  ``vags.direct_score="success"`` grasps): a move's gain over the same planner without moving;
* ``gdnet``: GDNet's own argmax from the global view, where the run plans its direct grasps
  otherwise (``vags.direct_score="success"``).

The states are the table's own (its worlds, steps and seed): the piles follow the direct grasp,
and the "direct" and "moved" outcomes repeat those of RUN/gate_states.npz (``agreement``, where
the device computes bit for bit).  Reported per subset (all states; where the gate grasps
directly; where it moves) and per object count (1, 2-5, 6-10): each branch's success, the paired
differences (``moved - direct``, ``oracle - direct``, ``moved - random``, ``moved - planned``)
with their standard errors, and the AUROC with which the gate's estimate (p_direct) and GDNet's Q at its grasp
(q_direct) rank the direct grasp's success.  Markdown on stdout; ``--out`` JSON; ``--rows`` the
per-state values (.npz: every branch's success, lost and seconds, the estimates, objects, and
``gate_moves``, the gate's decision) for analysis.
"""
from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from gate_estimates import auroc  # noqa: E402

BRANCHES = ("direct", "moved", "random", "oracle", "planned", "gdnet")
PAIRS = (("moved", "direct"), ("oracle", "direct"), ("moved", "random"), ("moved", "planned"))
OBJECTS = (("all", 1, 10 ** 6), ("1", 1, 1), ("2-5", 2, 5), ("6-10", 6, 10))


def paired(a, b) -> dict:
    """Mean and standard error of ``a - b`` over paired (N,) outcomes."""
    d = np.asarray(a, np.float64) - np.asarray(b, np.float64)
    se = float(np.std(d, ddof=1) / np.sqrt(d.size)) if d.size > 1 else None
    return {"difference": float(d.mean()) if d.size else None, "se": se}


def summarize(states: dict, moves) -> dict:
    """states: (N,) arrays (``<branch>_success``, ``p_direct``, ``q_direct``, ``objects``);
    moves: (N,) bool, the gate moves at that state -> {subset: {objects: figures}}."""
    moves = np.asarray(moves, bool)
    objects = np.asarray(states["objects"])
    out = {}
    for subset, keep in (("all", np.ones(moves.shape, bool)), ("gate: direct", ~moves), ("gate: move", moves)):
        out[subset] = {}
        for name, lo, hi in OBJECTS:
            m = keep & (objects >= lo) & (objects <= hi)
            e = {"states": int(m.sum())}
            for b in BRANCHES:
                if f"{b}_success" in states:
                    e[b] = float(np.mean(states[f"{b}_success"][m])) if m.any() else None
            for a, b in PAIRS:
                if f"{a}_success" in states and f"{b}_success" in states:
                    e[f"{a} - {b}"] = paired(states[f"{a}_success"][m], states[f"{b}_success"][m])
            direct = np.asarray(states["direct_success"])[m] > 0
            for col in ("p_direct", "q_direct"):
                v = auroc(np.asarray(states[col])[m], direct) if m.any() else float("nan")
                e[f"auroc_{col}"] = None if np.isnan(v) else v
            out[subset][name] = e
    return out


def table(summary: dict) -> str:
    """The summary as one Markdown table."""
    first = summary["all"]["all"]
    cols = [b for b in BRANCHES if b in first]
    pairs = [f"{a} - {b}" for a, b in PAIRS if f"{a} - {b}" in first]
    pct = lambda v: "-" if v is None else f"{100 * v:.1f}"  # noqa: E731
    diff = lambda e: ("-" if e["difference"] is None else  # noqa: E731
                      f"{100 * e['difference']:+.1f}" if e["se"] is None else
                      f"{100 * e['difference']:+.1f} ± {100 * e['se']:.1f}")
    num = lambda v: "-" if v is None else f"{v:.3f}"  # noqa: E731
    lines = ["| states | objects | n | " + " | ".join(f"{c} %" for c in cols) + " | " +
             " | ".join(f"{p} (points)" for p in pairs) + " | AUROC p_direct | AUROC q_direct |",
             "|---|---|---:|" + "---:|" * (len(cols) + len(pairs) + 2)]
    for subset, by_objects in summary.items():
        for name, e in by_objects.items():
            if e["states"] == 0:
                continue
            lines.append(f"| {subset} | {name} | {e['states']} | " + " | ".join(pct(e[c]) for c in cols) + " | " +
                         " | ".join(diff(e[p]) for p in pairs) +
                         f" | {num(e['auroc_p_direct'])} | {num(e['auroc_q_direct'])} |")
    return "\n".join(lines)


def agreement(states: dict, recorded) -> dict | None:
    """The share of states whose "direct" and "moved" outcomes equal those the run's table
    recorded (RUN/gate_states.npz); None when that file is missing or has other states."""
    if recorded is None or np.asarray(recorded["direct_success"]).shape != np.asarray(states["direct_success"]).shape:
        return None
    return {b: float(np.mean(np.asarray(states[f"{b}_success"]) == np.asarray(recorded[f"{b}_success"])))
            for b in ("direct", "moved")}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--run", required=True, help="a train.py run with stage 3's networks and its gate table")
    p.add_argument("--worlds", type=int, default=None, help="fresh piles (default: the table's)")
    p.add_argument("--steps", type=int, default=None, help="direct attempts per pile (default: the table's)")
    p.add_argument("--seed", type=int, default=None, help="(default: the table's)")
    p.add_argument("--out", default=None, help="write the figures as JSON here")
    p.add_argument("--rows", default=None, help="write the per-state values to this .npz")
    from vags_jax import cli
    cli.add_cache_dir(p)
    args = p.parse_args(argv)
    error = cli.use_compile_cache("gate_headroom.py", args.cache_dir)
    if error is not None:
        return error

    import jax

    from vags_jax.policies import rate_gate
    from vags_jax.stages import checkpoint, gate_measure, rundir

    try:
        cfg = checkpoint.load_config(args.run)
    except (checkpoint.CheckpointError, FileNotFoundError, ValueError) as e:
        print(f"gate_headroom.py: {e}", file=sys.stderr)
        return 2
    d = rate_gate.read(args.run)
    if d is None:
        print(f"gate_headroom.py: {args.run} has no gate table ({rate_gate.GATE_FILE}); measure it first: "
              f"{gate_measure.PROG} --run {args.run}", file=sys.stderr)
        return 2
    gate = rate_gate.load_table(args.run, max_motion_number=cfg.vags.max_motion_number)
    pick = rundir.picked_gdnet(args.run, cfg, d.get("networks"))
    try:
        _, meta, states = gate_measure.measure(
            args.run, worlds=args.worlds or d.get("worlds"), steps=args.steps or d.get("steps"),
            seed=d.get("seed") if args.seed is None else args.seed, gdnet=pick,
            estimate=rate_gate.estimate_of(args.run), close_score=rate_gate.close_score_of(args.run),
            direct_score=rate_gate.direct_score_of(args.run), extra=gate_measure.EXTRA_BRANCHES,
            log=lambda m: print(m, file=sys.stderr, flush=True))
    except (ValueError, checkpoint.CheckpointError, FileNotFoundError) as e:
        print(f"gate_headroom.py: {e}", file=sys.stderr)
        return 2
    moves = rate_gate.moves_at(gate, states["p_direct"])
    summary = summarize(states, moves)
    own_states = args.worlds is None and args.steps is None and args.seed is None
    same = agreement(states, rate_gate.read_states(args.run)) if own_states else None
    if args.rows:
        os.makedirs(os.path.dirname(os.path.abspath(args.rows)), exist_ok=True)
        np.savez_compressed(args.rows, gate_moves=moves, **states)
    print(table(summary))
    print(f"{int(moves.sum())} of {moves.size} states in the gate's moving bins; outcomes equal to the run's "
          f"table: {same}")
    if args.out:
        os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
        with open(args.out, "w") as f:
            json.dump({"run": args.run, "gdnet_pick": pick, "moving_bins": rate_gate.moves_summary(gate),
                       "max_motion_number": cfg.vags.max_motion_number, "measure": meta,
                       "agreement_with_run_table": same, "summary": summary,
                       "device": str(jax.devices()[0])}, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
