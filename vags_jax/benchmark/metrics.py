"""Benchmark metrics: per-round outcomes, the robot-time model and the report table.

Per group and ``overall`` (pooled over every round of every group), ``summarize`` gives:

* grasp success rate = successful grasps / grasp attempts;
* scene clearing rate = cleared rounds / rounds, a round is *cleared* when every one of its
  objects was grasped (objects pushed off the workspace do not count as cleared);
* motion number = camera-or-gripper motions / successfully grasped objects (1 per direct grasp,
  2 per grasp after a viewpoint move, 1 per push);
* picks per hour = successful grasps / hours of modelled robot time (``MotionTimeModel``);

and diagnostics beside them: the share of attempts that moved the camera first
(``viewpoint_rate``), the success of those attempts and of the direct ones
(``success_after_move``, ``success_direct``), the success of each round's first attempt
(``first_attempt_success``: its pile has just been dropped), attempts per round, the share aimed
at an object cell (``on_object_rate``), objects lost (left the table without a grasp), physics
errors.
"""
from __future__ import annotations

import dataclasses
import json
import os
from dataclasses import dataclass
from typing import Any, Optional, Sequence

import jax
import numpy as np
from flax import struct

from vags_jax.config import Config, to_dict


# ----------------------------------------------------------------------------- time model


@dataclass(frozen=True)
class MotionTimeModel:
    """Modelled robot time of a round, the same for every method (picks per hour).

    Per round (sums over its attempts; counters from ``RoundOutcomes``)::

        seconds = motions * capture_s                     # one RGB-D capture per motion
                + (travel + return_travel) / speed         # every commanded Cartesian move
                + attempts * (close_s + lift_s)            # closing the jaw; lift overhead
                + successes * place_s                      # to the bin, release, back

    ``travel`` is what ``EnvState.travel`` accumulates: the camera moves before the grasp (global
    pose -> viewpoint, for attempts that adjust the viewpoint), the approach (last capture pose
    -> 15 cm above the grasp point), descend, lift.  ``return_travel`` (failed attempts only) is the straight line
    from the lifted gripper back to the global capture pose; after a success ``place_s`` covers
    the trip to the bin and back.  ``lift_s`` is the fixed part of a lift (grip check, slow
    start with a load) on top of its distance / speed.  Defaults are round numbers for a UR5 +
    RG2 cell moving at 0.5 m/s; they are not measured on a robot.  The values come from the
    config's ``benchmark`` section (``from_config``).
    """

    speed: float = 0.5  # m/s, Cartesian gripper speed
    capture_s: float = 0.5  # s per motion: RGB-D capture + inference at the reached pose
    close_s: float = 0.5  # s per attempt: closing the gripper
    lift_s: float = 0.5  # s per attempt: fixed lift overhead
    place_s: float = 2.0  # s per success: carry to the bin, release, return to the capture pose

    @staticmethod
    def from_config(cfg: Config) -> "MotionTimeModel":
        """The time model of the config's ``benchmark`` section."""
        b = cfg.benchmark
        return MotionTimeModel(speed=b.speed, capture_s=b.capture_s, close_s=b.close_s, lift_s=b.lift_s,
                               place_s=b.place_s)

    def __post_init__(self):
        if not self.speed > 0:
            raise ValueError(f"MotionTimeModel.speed must be > 0 m/s, got {self.speed}")
        for name in ("capture_s", "close_s", "lift_s", "place_s"):
            if getattr(self, name) < 0:
                raise ValueError(f"MotionTimeModel.{name} must be >= 0 seconds, got {getattr(self, name)}")

    def round_seconds(self, attempts, successes, motions, travel, return_travel) -> np.ndarray:
        """(R,) modelled seconds of R rounds from their (R,) counters (numpy or jnp)."""
        return (np.asarray(motions) * self.capture_s
                + (np.asarray(travel) + np.asarray(return_travel)) / self.speed
                + np.asarray(attempts) * (self.close_s + self.lift_s)
                + np.asarray(successes) * self.place_s)


# ----------------------------------------------------------------------------- outcomes, metrics


@struct.dataclass
class RoundOutcomes:
    """Per-round results of R rounds, every field (R,) (numpy after ``Evaluator.run_group``).

    n_objects: objects at the start; attempts / successes / motions: counts; travel: commanded
    gripper travel (m); return_travel: return moves after failed attempts (m); remaining:
    objects still on the table at the end; on_object: attempts aimed at an object cell of the
    global height map (diagnostic: a grasp aimed at bare table cannot succeed); viewpoints:
    attempts that moved the camera to a viewpoint before grasping (motions > 1); error: physics
    failure (NaN / tunnelling) ended the round; overflow: a warp contact buffer was full at some step (results unreliable).
    scores: (R, T) the planner's decision value of each attempt (``Attempt.score``; VAGS: GDNet's
    largest Q), NaN after the round's last attempt or for planners without one.
    pushes: pushes (VPG: one motion each, no grasp attempt; ``attempts`` counts grasps only),
    None for policies that never push.
    lost_after_move: the part of the objects lost (``lost``) knocked off by attempts made after
    a viewpoint move.
    successes_after_move: the part of ``successes`` made by attempts after a viewpoint move.
    first_success: bool, the round's first grasp attempt succeeded (False in a round without one).
    lost_at_start: the part of the objects lost (``lost``) already gone when the round's first
    attempt began: drawn, but outside the workspace or through the table after the pile's drop.
    redraws: how many times the round's pile was redone because its drop spilled an object:
    drawn again (``benchmark.redraw_spilled``) or its spilled objects dropped again
    (``benchmark.redrop_spilled``).
    The last five are None in outcomes recorded before they existed.
    """

    n_objects: Any
    attempts: Any
    successes: Any
    motions: Any
    travel: Any
    return_travel: Any
    remaining: Any
    on_object: Any
    viewpoints: Any
    error: Any
    overflow: Any
    scores: Any = None
    pushes: Any = None
    lost_after_move: Any = None
    successes_after_move: Any = None
    first_success: Any = None
    lost_at_start: Any = None
    redraws: Any = None

    @property
    def cleared(self) -> np.ndarray:
        """(R,) bool: every object of the round was grasped."""
        return np.asarray(self.successes) >= np.asarray(self.n_objects)

    @property
    def lost(self) -> np.ndarray:
        """(R,) objects that left the table without being grasped (pushed off, fell through)."""
        return np.asarray(self.n_objects) - np.asarray(self.successes) - np.asarray(self.remaining)

    @staticmethod
    def concatenate(parts: Sequence["RoundOutcomes"]) -> "RoundOutcomes":
        return jax.tree.map(lambda *xs: np.concatenate([np.asarray(x) for x in xs]), *parts)

    def to_json(self) -> dict:
        return {f.name: np.asarray(getattr(self, f.name)).tolist() for f in dataclasses.fields(self)
                if getattr(self, f.name) is not None}


def wilson_interval(k: int, n: int, z: float = 1.959964) -> Optional[tuple[float, float]]:
    """The Wilson score interval (95 % for the default z) of a rate of k successes in n trials
    -> (low, high), or None when n is 0."""
    if n <= 0:
        return None
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return float(max(0.0, centre - half)), float(min(1.0, centre + half))


def _ratio(num: float, den: float) -> Optional[float]:
    return float(num) / float(den) if den > 0 else None


def summarize(out: RoundOutcomes, time_model: MotionTimeModel = MotionTimeModel()) -> dict:
    """Benchmark metrics of a set of rounds (a group, or all groups pooled for ``overall``).

    Ratios whose denominator is 0 (no attempts, no successes, no time) are None.
    """
    attempts = int(np.sum(out.attempts))
    successes = int(np.sum(out.successes))
    motions = int(np.sum(out.motions))
    seconds = float(np.sum(time_model.round_seconds(out.attempts, out.successes, out.motions,
                                                    out.travel, out.return_travel)))
    rounds = int(np.size(out.n_objects))
    return {
        "rounds": rounds,
        "objects": int(np.sum(out.n_objects)),
        "attempts": attempts,
        "successes": successes,
        "motions": motions,
        "grasp_success_rate": _ratio(successes, attempts),
        "clearing_rate": _ratio(int(np.sum(out.cleared)), rounds),
        "motion_number": _ratio(motions, successes),
        "picks_per_hour": _ratio(successes, seconds / 3600.0),
        "robot_seconds": seconds,
        "attempts_per_round": _ratio(attempts, rounds),
        "on_object_rate": _ratio(int(np.sum(out.on_object)), attempts),
        "viewpoint_rate": _ratio(int(np.sum(out.viewpoints)), attempts),
        "objects_lost": int(np.sum(out.lost)),
        "physics_errors": int(np.sum(out.error)),
        "buffer_overflows": int(np.sum(out.overflow)),
        **({} if out.pushes is None else {"pushes": int(np.sum(out.pushes))}),
        **({} if out.lost_after_move is None else {"objects_lost_after_move": int(np.sum(out.lost_after_move))}),
        **({} if out.lost_at_start is None else {"objects_lost_at_start": int(np.sum(out.lost_at_start))}),
        **({} if out.redraws is None else {"scenes_redrawn": int(np.sum(np.asarray(out.redraws) > 0))}),
        **_by_branch(out, attempts, successes),
    }


def _by_branch(out: RoundOutcomes, attempts: int, successes: int) -> dict:
    """``success_after_move`` / ``success_direct`` (attempts after a viewpoint move and the
    rest) and ``first_attempt_success`` (rounds with at least one attempt), where recorded."""
    m = {}
    if out.successes_after_move is not None:
        views, after = int(np.sum(out.viewpoints)), int(np.sum(out.successes_after_move))
        m.update(success_after_move=_ratio(after, views), success_direct=_ratio(successes - after, attempts - views))
    if out.first_success is not None:
        started = np.asarray(out.attempts) > 0
        m["first_attempt_success"] = _ratio(int(np.sum(np.asarray(out.first_success)[started])), int(started.sum()))
    return m


# ----------------------------------------------------------------------------- report


def _pct(x) -> str:
    return "-" if x is None else f"{100 * x:.1f}"


def _num(x, fmt="{:.2f}") -> str:
    return "-" if x is None else fmt.format(x)


def format_table(report: dict) -> str:
    """Markdown table: one row per group and one for the pooled overall."""
    pushes = "pushes" in report["overall"]  # a policy that pushes (VPG): one more column
    head = ("| objects | rounds | attempts | successes | grasp success % | clearing % | motion number "
            "| picks/hour | viewpoint % | attempts/round | on object % | lost | errors |" + (" pushes |" if pushes else ""))
    rows = [head, "|" + "|".join(["---:"] * (head.count("|") - 1)) + "|"]

    def row(name, m):
        return (f"| {name} | {m['rounds']} | {m['attempts']} | {m['successes']} | "
                f"{_pct(m['grasp_success_rate'])} | {_pct(m['clearing_rate'])} | {_num(m['motion_number'])} | "
                f"{_num(m['picks_per_hour'], '{:.0f}')} | {_pct(m.get('viewpoint_rate'))} | "
                f"{_num(m['attempts_per_round'], '{:.1f}')} | "
                f"{_pct(m['on_object_rate'])} | {m['objects_lost']} | {m['physics_errors']} |"
                + (f" {m['pushes']} |" if pushes else ""))

    for m in report["groups_metrics"]:
        rows.append(row(str(m["n_objects"]), m))
    rows.append(row("**overall**", report["overall"]))
    return "\n".join(rows)


# One line per column of ``format_table`` (docs/benchmark.md, "Metrics", defines each in full).
TABLE_LEGEND = (
    ("objects", "objects on the table at the start of each round of the group"),
    ("rounds", "rounds played, one world each"),
    ("attempts", "grasp attempts (one grasp each, after 0 or more camera moves)"),
    ("successes", "successful grasps (an object lifted clear of the table)"),
    ("grasp success %", "successful grasps / grasp attempts"),
    ("clearing %", "rounds whose every object was grasped / rounds"),
    ("motion number", "camera and gripper motions per grasped object (direct grasp 1, viewpoint move + grasp 2)"),
    ("picks/hour", "successful grasps per hour of modelled robot time (docs/benchmark.md, time model)"),
    ("viewpoint %", "attempts that first moved the camera to a close viewpoint"),
    ("attempts/round", "grasp attempts per round (at most 2 x objects + benchmark.max_attempts_extra)"),
    ("on object %", "attempts aimed at a heightmap cell that shows an object (bare table cannot succeed)"),
    ("lost", "objects that left the table without being grasped (pushed or knocked off)"),
    ("errors", "rounds ended by a physics failure (NaN or an object through the table)"),
)


def format_branches(m: dict) -> Optional[str]:
    """One line of ``summarize``'s success by branch (first attempts of the rounds, direct grasps,
    grasps after a viewpoint move), or None for outcomes that do not record it."""
    if "first_attempt_success" not in m:
        return None
    views = round((m["viewpoint_rate"] or 0.0) * m["attempts"])
    return (f"success of the rounds' first attempts {_pct(m['first_attempt_success'])} %, of direct grasps "
            f"{_pct(m.get('success_direct'))} %, of grasps after a move {_pct(m.get('success_after_move'))} % "
            f"({views} of {m['attempts']} attempts)")


def format_spills(m: dict, redraw: int = 0, redrop: int = 0) -> Optional[str]:
    """One line on the piles whose drop spilled an object before the round's first attempt
    (``summarize``'s ``objects_lost_at_start`` and ``scenes_redrawn``), with the remedy the
    config set (``benchmark.redraw_spilled`` / ``redrop_spilled``), or None when no pile spilled
    and none was redone."""
    start, redone = m.get("objects_lost_at_start") or 0, m.get("scenes_redrawn") or 0
    if not start and not redone:
        return None
    objects = f"{start} object{'' if start == 1 else 's'}"
    if redraw or redrop:
        how = f"benchmark.redraw_spilled={redraw}" if redraw else f"benchmark.redrop_spilled={redrop}"
        return (f"spilled piles: {redone} round{'' if redone == 1 else 's'} redone ({how}); {objects} still off "
                f"the table at the start of their round")
    return (f"spilled piles: {objects} off the table before their round's first attempt (the pile's "
            f"drop threw {'it' if start == 1 else 'them'} out), and a round that lost one cannot be cleared; --set "
            f"benchmark.redrop_spilled=N drops them again (docs/benchmark.md, \"Spilled piles\")")


def format_legend() -> str:
    """The table's columns, one line each, to print under ``format_table``."""
    width = max(len(k) for k, _ in TABLE_LEGEND)
    return "\n".join(f"  {k:<{width}}  {v}" for k, v in TABLE_LEGEND)


def save_report(report: dict, path: str, cfg: Optional[Config] = None, extra: Optional[dict] = None) -> None:
    """Writes the report (plus the config and ``extra`` metadata) as JSON."""
    data = dict(report)
    if cfg is not None:
        data["config"] = to_dict(cfg)
    if extra:
        data.update(extra)
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, "w") as f:
        json.dump(data, f, indent=1)


def format_seeds(name: str, overall: dict) -> str:
    """A Markdown table of each seed's overall figures (``{seed: report["overall"]}``) and their mean."""
    keys = [("grasp_success_rate", "grasp success %", 100), ("clearing_rate", "clearing %", 100),
            ("motion_number", "motion number", 1), ("viewpoint_rate", "viewpoint %", 100)]
    fmt = lambda x, m: "-" if x is None else f"{x * m:.{1 if m == 100 else 2}f}"  # noqa: E731
    lines = [f"| {name}: seed | " + " | ".join(k[1] for k in keys) + " |", "|---" * (len(keys) + 1) + "|"]
    for seed, o in overall.items():
        lines.append(f"| {seed} | " + " | ".join(fmt(o.get(k), m) for k, _, m in keys) + " |")
    mean = []
    for k, _, m in keys:
        vals = [o.get(k) for o in overall.values()]
        mean.append("-" if None in vals else f"**{fmt(sum(vals) / len(vals), m)}**")
    lines.append("| **mean** | " + " | ".join(mean) + " |")
    return "\n".join(lines)
