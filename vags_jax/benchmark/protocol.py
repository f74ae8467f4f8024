"""The benchmark of docs/benchmark.md (paper section 4.4) for the policies that exist now.

Protocol.  For every group size ``k`` (default 1..10) run ``R`` rounds (default 50).  Every
round is one world, and all rounds of all groups play at once in ONE batch of G x R worlds
(``Evaluator.run_groups``; ``evaluate(..., batch_groups=False)`` plays one group per batch):
a round of group ``k`` starts with ``k`` objects drawn from the object set (random shapes,
sizes, colours, poses: ``VagsEnv.step_reset``).  A round ends when the
table is clear, after ``2 * k + cfg.benchmark.max_attempts_extra`` grasp attempts, or on a physics
error.  The attempts run inside one jitted ``lax.while_loop`` that stops when every round is
over; a finished world's state is frozen (its physics may still be computed, its outcome is
dropped), so the per-world counters of ``EnvState`` are exactly the round's.

Policies (``make_policy``) plan one attempt per world, ``(params, key, env, EnvState) ->
env.Attempt`` (grasp pose, where its approach starts, motions).  All but the GG-CNN ones choose
an action ``(B, 3) int32 [rotation, row, col]`` on the global heightmaps (1 motion):

* ``gdnet``: greedy argmax of GDNet's Q over (rotation, row, col) -- no exploration.  Its
  ``params`` are the online ``{"params", "batch_stats"}`` of a stage-1 checkpoint.
* ``random``: a uniformly random object pixel (height > ``exploration.height_threshold``;
  any pixel when none) and a uniformly random rotation.  Sanity floor.
* ``highest``: the highest point of the height map (box-smoothed over ~3 cm so that the middle
  of a flat top beats its edges and single tall pixels), rotation 0.  The simplest scripted grasp.
* ``heuristic``: scripted minimum-width grasp.  Take the ``highest`` point; for each of the
  ``n_rotations / 2`` distinct closing axes, walk the height map outwards from it along the
  axis and measure the contiguous run of cells that would stand between the open fingers at
  grasp depth (height > surface - ``depth_below_surface``, and an object cell); choose the axis
  with the narrowest run that fits in ``finger_stroke`` (the narrowest one if none fits), and
  move the grasp centre to the middle of that run.
* ``vags``: the method (``vags_plan``, ``vags_jax.policies.decision``): where the gate's score is above
  the threshold, grasp directly at GDNet's argmax (1 motion); else move the camera to VANet's
  argmax viewpoint and grasp with the close-view planner (2 motions).  ``params`` =
  ``{"gdnet", "vanet", "success", "ggcnn", "threshold"}`` (``pipeline.load_vags``); the
  threshold is an argument of the compiled loop, so a threshold sweep compiles once.  A
  threshold of -inf is the VANet ablation (GDNet alone, ``eval.py --no-viewpoint``).
* ``ggcnn``: GG-CNN on the raw depth image of the global camera, 1 motion (the paper's GG-CNN
  baseline).  ``ggcnn-close``: move the camera 25 cm above the ``highest`` cell, take a depth
  image there and grasp at GG-CNN's best grasp, 2 motions.  Both need a GG-CNN trained by
  ``train.py --stage ggcnn``.

Metrics (``summarize``; per group, and ``overall`` pooled over every round of every group):

* grasp success rate = successful grasps / grasp attempts;
* scene clearing rate = cleared rounds / rounds, a round is *cleared* when every one of its
  objects was grasped (objects pushed off the workspace do not count as cleared);
* motion number = camera-or-gripper motions / successfully grasped objects (1 per direct grasp,
  2 per grasp after a viewpoint move);
* picks per hour = successful grasps / hours of modelled robot time (``MotionTimeModel``).

Diagnostics beside them: the share of attempts that moved the camera to a viewpoint first
(``viewpoint_rate``), attempts per round, the share of attempts aimed at an object cell
(``on_object_rate``), objects lost (left the table without a grasp), physics errors.

Reproducible: the scenes of group ``k`` come from ``jax.random.fold_in(PRNGKey(seed), k)``,
one key per round, so adding or removing other groups does not change them (changing the
number of rounds does).  The policies' random draws and the sensor noise during the rounds
come from the seed and the whole batch.
"""
from __future__ import annotations

import dataclasses
import json
import math
import os
import time
import warnings
from dataclasses import dataclass
from typing import Any, Callable, Optional, Sequence

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from vags_jax.config import Config, to_dict
from vags_jax.perception import camera
from vags_jax.config import benchmark_groups
from vags_jax.env import Attempt, EnvState, VagsEnv, where_worlds

POLICIES = ("vags", "gdnet", "ggcnn", "ggcnn-close", "random", "highest", "heuristic")
DEFAULT_GROUPS = tuple(range(1, 11))  # the paper's; the config's ``benchmark`` section decides
DEFAULT_ROUNDS = 50


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
    }


# ----------------------------------------------------------------------------- policies


@dataclass(frozen=True)
class Policy:
    """A grasping policy for the benchmark.

    plan: ``(params, key, env: VagsEnv, state: EnvState) -> Attempt``, pure and jittable: per
    world, the grasp (world position, yaw), where its approach starts and how many motions the
    attempt takes (``vags_jax.env.Attempt``: a grasp planned on the global view is 1 motion, one
    after a viewpoint move 2).  ``params``: a pytree passed to the compiled loop as an argument
    (network weights), or None.  ``act``: for policies that choose a heightmap action on the
    global view, ``(params, key, state) -> action (B, 3) int32 [rotation, row, col]`` (``plan``
    executes it, 1 motion); None for the others.
    """

    name: str
    plan: Callable
    params: Any = None
    act: Optional[Callable] = None


def heightmap_policy(name: str, act: Callable, params: Any = None) -> Policy:
    """A policy acting on the global heightmaps: ``act(params, key, state) -> (B, 3) [rotation,
    row, col]``, executed as a direct grasp (``VagsEnv.grasp_pose``, 1 motion)."""

    def plan(params, key, env: VagsEnv, state: EnvState) -> Attempt:
        action = act(params, key, state)
        position, yaw = env.grasp_pose(state, action[:, 1:], action[:, 0])
        return env.direct_attempt(position, yaw)

    return Policy(name, plan, params, act)


def ggcnn_plan(cfg: Config, close: bool) -> Callable:
    """GG-CNN planners.  ``close=False`` (policy ``ggcnn``, the paper's GG-CNN baseline): GG-CNN
    on the raw depth image of the fixed global camera, 1 motion.  ``close=True`` (``ggcnn-close``):
    move the camera to the viewpoint ``camera.viewpoint_height`` above the highest object cell of
    the global heightmap (``_highest_pixel``), take the raw depth image there, grasp at GG-CNN's
    best grasp; 2 motions.  ``params`` = ``{"params": ...}`` of GG-CNN."""
    from vags_jax.ggcnn.planner import predict_grasp
    from vags_jax.nets.ggcnn import GGCNN

    model = GGCNN()

    def plan(params, key, env: VagsEnv, state: EnvState) -> Attempt:
        B = state.n_worlds
        pose = env.viewpoint_pose(state, _highest_pixel(state.height, cfg)) if close else env.global_poses(B)
        image = env.camera_image(state.sim, pose, key)
        grasp, _ = predict_grasp(model, params, image.depth, pose, cfg.camera, cfg.ggcnn,
                                 cfg.grasp.depth_below_surface)
        if close:
            return env.viewpoint_attempt(grasp.position, grasp.yaw, pose)
        return env.direct_attempt(grasp.position, grasp.yaw)

    return plan


def vags_plan(cfg: Config) -> Callable:
    """VAGS's planner (``decision.VagsNets``: the gate, then a direct grasp or the close-view
    planner's): params = ``vags_params(...)``.  The attempt's ``score`` is the gate's score."""
    from vags_jax.policies.decision import VagsNets

    nets = VagsNets(cfg)

    def plan(params, key, env: VagsEnv, state: EnvState) -> Attempt:
        return nets.plan(params, key, env, state)[0]

    return plan


def vags_params(networks, cfg: Config, threshold=None) -> dict:
    """The ``vags`` policy's params from ``pipeline.VagsNetworks``: the gate's threshold is the
    run's ("q" gate) or ``-vags.move_cost`` ("success" gate), unless ``threshold`` overrides it
    (e.g. ``-inf`` for the VANet ablation).  ValueError when the config's gate or close-view
    planner needs a network the run lacks."""
    from vags_jax.policies.decision import gate_threshold

    if cfg.vags.gate == "success" and networks.success is None:
        raise ValueError(f"the run's networks ({networks.source}) have no success net (trained before the "
                         f"'success' gate): evaluate with --set vags.gate=q, or train the run again")
    if cfg.vags.local_planner == "ggcnn" and networks.ggcnn is None:
        raise ValueError("vags.local_planner=ggcnn needs a GG-CNN in the run (RUN/ggcnn): train one with "
                         "python train.py --stage ggcnn --out RUN")
    thr = gate_threshold(cfg.vags, networks.q_threshold) if threshold is None else threshold
    params = {"gdnet": networks.gdnet, "vanet": networks.vanet, "threshold": jnp.asarray(thr, jnp.float32)}
    if networks.ggcnn is not None:
        params["ggcnn"] = networks.ggcnn
    if networks.success is not None:
        params["success"] = networks.success
    if networks.calibration is not None:
        params["calibration"] = networks.calibration
    return params


def _object_mask(height: jax.Array, threshold: float) -> jax.Array:
    """(B, H, W) -> (B, H, W) bool object cells; all True in maps without any."""
    mask = height > threshold
    return jnp.where(mask.any(axis=(1, 2), keepdims=True), mask, True)


def _smooth(height: jax.Array, size: int) -> jax.Array:
    """(B, H, W) box mean over size x size cells (zero padding)."""
    if size <= 1:
        return height
    s = jax.lax.reduce_window(height, 0.0, jax.lax.add, (1, size, size), (1, 1, 1), "SAME")
    return s / float(size * size)


def _highest_pixel(height: jax.Array, cfg: Config) -> jax.Array:
    """(B, H, W) -> (B, 2) int32 [row, col] among object cells: argmax of the box-smoothed
    height (window ~3 cm, at least 3 cells), ties (a flat top) broken toward the cell with the
    most object around it (window ~6 cm, worth at most 1 mm of height): the middle of the top."""
    px = cfg.workspace.pixel_size
    size = max(3, int(round(0.03 / px))) | 1  # odd
    obj = height > cfg.exploration.height_threshold
    score = _smooth(height, size) + 1e-3 * _smooth(obj.astype(jnp.float32), 2 * size + 1)
    score = jnp.where(_object_mask(height, cfg.exploration.height_threshold), score, -jnp.inf)
    b, h, w = height.shape
    flat = jnp.argmax(score.reshape(b, -1), axis=1)
    return jnp.stack(jnp.unravel_index(flat, (h, w)), axis=-1).astype(jnp.int32)


def random_act(cfg: Config) -> Callable:
    """Uniform object pixel (any pixel when the map is empty) + uniform rotation."""
    thr, R = cfg.exploration.height_threshold, cfg.grasp.n_rotations

    def act(params, key, state: EnvState):
        del params
        b, h, w = state.height.shape
        k_pix, k_rot = jax.random.split(key)
        logits = jnp.where(_object_mask(state.height, thr), 0.0, -jnp.inf).reshape(b, -1)
        flat = jax.random.categorical(k_pix, logits, axis=-1)
        row, col = jnp.unravel_index(flat, (h, w))
        rot = jax.random.randint(k_rot, (b,), 0, R)
        return jnp.stack([rot, row, col], axis=-1).astype(jnp.int32)

    return act


def highest_act(cfg: Config) -> Callable:
    """Highest (smoothed) point, rotation 0."""

    def act(params, key, state: EnvState):
        del params, key
        pix = _highest_pixel(state.height, cfg)
        return jnp.concatenate([jnp.zeros_like(pix[:, :1]), pix], axis=1)

    return act


def min_width_grasp(height: jax.Array, cfg: Config):
    """The ``heuristic`` policy's choice on height maps (B, H, W).

    Returns ``action (B, 3) int32 [rotation, row, col]`` (rotation in 0..n_rotations/2-1) and
    ``width (B,) float32``: the measured extent (m) between the fingers along the chosen axis.
    """
    ws, g = cfg.workspace, cfg.grasp
    b, h, w = height.shape
    px = ws.pixel_size
    centre = _highest_pixel(height, cfg)  # (B, 2)
    bi = jnp.arange(b)
    surface = height[bi, centre[:, 0], centre[:, 1]]
    level = jnp.maximum(surface - g.depth_below_surface, cfg.exploration.height_threshold)  # (B,)

    n_axes = max(1, g.n_rotations // 2)
    theta = jnp.arange(n_axes, dtype=jnp.float32) * g.rotation_step  # (A,)
    axis = jnp.stack([jnp.sin(theta), jnp.cos(theta)], axis=-1)  # (A, 2) in (row, col)
    step = 0.5  # cells per sample along the axis
    n_steps = int(math.ceil(g.finger_stroke / 2 / px / step)) + 2
    steps = step * jnp.arange(1, n_steps + 1, dtype=jnp.float32)  # (S,) cells from the centre
    sides = jnp.array([1.0, -1.0])
    # (B, A, 2 sides, S, 2) sample cells along the axis, nearest neighbour.
    off = sides[None, :, None, None] * steps[None, None, :, None] * axis[:, None, None, :]
    pts = jnp.round(centre[:, None, None, None, :].astype(jnp.float32) + off[None]).astype(jnp.int32)
    inside = ((pts >= 0) & (pts < jnp.array([h, w]))).all(-1)
    ptsc = jnp.clip(pts, 0, jnp.array([h - 1, w - 1]))
    hs = height[bi[:, None, None, None], ptsc[..., 0], ptsc[..., 1]]
    occupied = inside & (hs > level[:, None, None, None])
    run = jnp.cumprod(occupied.astype(jnp.int32), axis=-1).sum(-1)  # (B, A, 2) samples per side
    width = (step * run.sum(-1) + 1).astype(jnp.float32) * px  # (B, A) metres
    fits = width <= g.finger_stroke - 2 * px
    score = jnp.where(fits, width, width + 1e3)
    best = jnp.argmin(score, axis=1)  # (B,)
    shift = 0.5 * step * (run[bi, best, 0] - run[bi, best, 1]).astype(jnp.float32)  # toward + side
    grasp = jnp.round(centre.astype(jnp.float32) + shift[:, None] * axis[best])
    grasp = jnp.clip(grasp, 0, jnp.array([h - 1, w - 1])).astype(jnp.int32)
    action = jnp.concatenate([best[:, None].astype(jnp.int32), grasp], axis=1)
    return action, width[bi, best]


def heuristic_act(cfg: Config) -> Callable:
    def act(params, key, state: EnvState):
        del params, key
        return min_width_grasp(state.height, cfg)[0]

    return act


def gdnet_act(cfg: Config) -> Callable:
    """Greedy GDNet: params = {"params", "batch_stats"} of the online network."""
    from vags_jax.nets import make_qnet

    net = make_qnet(cfg.net, "gdnet")

    def act(params, key, state: EnvState):
        del key
        q = net.apply(params, state.color, state.height, False)  # (B, R, H, W)
        b, r, h, w = q.shape
        flat = jnp.argmax(q.reshape(b, -1), axis=1)
        return jnp.stack(jnp.unravel_index(flat, (r, h, w)), axis=-1).astype(jnp.int32)

    return act


def make_policy(name: str, cfg: Config, gdnet_variables: Any = None, ggcnn_params: Any = None,
                vags_networks: Any = None, threshold: Optional[float] = None) -> Policy:
    """Policy by name (``POLICIES``); ``gdnet`` needs ``gdnet_variables`` ({"params",
    "batch_stats"}, e.g. from ``load_gdnet``); ``ggcnn`` / ``ggcnn-close`` need
    ``ggcnn_params`` ({"params"}, e.g. from ``ggcnn_stage.load_ggcnn``); ``vags`` needs
    ``vags_networks`` (``pipeline.load_vags``) and takes ``threshold`` (default: the run's)."""
    if name not in POLICIES:
        raise ValueError(f"unknown policy {name!r}; choose one of {', '.join(POLICIES)}")
    if name == "vags":
        if vags_networks is None:
            raise ValueError("policy 'vags' needs the trained networks of a run (eval.py --run RUN after "
                             "train.py's stage 2 or 3), or pass vags_networks")
        return Policy("vags", vags_plan(cfg), vags_params(vags_networks, cfg, threshold))
    if name == "gdnet":
        if gdnet_variables is None:
            raise ValueError("policy 'gdnet' needs trained GDNet variables: evaluate a run "
                             "directory (eval.py --run RUN) or pass gdnet_variables")
        return heightmap_policy("gdnet", gdnet_act(cfg), gdnet_variables)
    if name in ("ggcnn", "ggcnn-close"):
        if ggcnn_params is None:
            raise ValueError(f"policy {name!r} needs trained GG-CNN parameters: evaluate a run with a GG-CNN "
                             f"(train.py --stage ggcnn --out RUN, then eval.py --run RUN) or pass ggcnn_params")
        return Policy(name, ggcnn_plan(cfg, close=name == "ggcnn-close"), ggcnn_params)
    return heightmap_policy(name, {"random": random_act, "highest": highest_act, "heuristic": heuristic_act}[name](cfg))


# ----------------------------------------------------------------------------- checkpoint


def load_gdnet(run_dir: str, step: Optional[int] = None):
    """Restores only the GDNet learner of a stage-1 run -> ``(run_cfg, variables, step)``.

    ``variables`` = ``{"params", "batch_stats"}`` of the online network.  Checkpoints store each
    part of ``Stage1State`` under its name, so only ``learner`` is read: the worlds and the replay
    buffer (gigabytes at scale) are neither built nor loaded.
    Raises ``checkpoint.CheckpointError`` (a ValueError) with what to fix.
    """
    from vags_jax.stages import checkpoint
    from vags_jax.rl import dqn
    from vags_jax.nets import init_qnet, make_qnet

    cfg = checkpoint.load_config(run_dir) if os.path.isdir(run_dir) else None
    if cfg is None:
        raise checkpoint.CheckpointError(f"run directory {run_dir!r} does not exist")
    H = cfg.workspace.heightmap_px
    net = make_qnet(cfg.net, "gdnet")
    target = jax.eval_shape(lambda k: dqn.create_train_state(init_qnet(k, net, H, H), cfg.dqn),
                            jax.random.PRNGKey(0))
    target = jax.tree.map(lambda x: np.zeros(x.shape, x.dtype), target)  # host zeros: nothing compiled
    learner, step = checkpoint.restore_part(run_dir, "learner", target, step)
    return cfg, {"params": learner.params, "batch_stats": learner.batch_stats}, step


# ----------------------------------------------------------------------------- evaluator


@struct.dataclass
class _Carry:
    env: EnvState
    done: jax.Array  # (B,) bool
    return_travel: jax.Array  # (B,) float32
    on_object: jax.Array  # (B,) int32
    viewpoints: jax.Array  # (B,) int32
    scores: jax.Array  # (B, T) float32, NaN where no attempt was made
    key: jax.Array
    t: jax.Array  # () int32


def check_groups(groups: Sequence[int], cfg: Config, rounds: int = 1) -> tuple[int, ...]:
    """Validates group sizes and rounds against the config; returns the groups as ints."""
    N = cfg.scene.max_objects
    groups = tuple(groups)
    if not groups:
        raise ValueError("groups: give at least one group size (number of objects), e.g. 1,2,3")
    for k in groups:
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)):
            raise ValueError(f"groups must be integers (numbers of objects), got {k!r}")
    bad = [int(k) for k in groups if not 1 <= k <= N]
    if bad:
        raise ValueError(
            f"group sizes {bad} are outside 1..{N}: the scene holds at most scene.max_objects = {N} "
            f"objects. Evaluate groups within 1..{N}, or use an evaluation config with "
            f"scene.max_objects >= {max(bad)} (e.g. --set scene.max_objects={max(bad)}; the object "
            f"pool len(scene.shapes) * scene.copies_per_shape = {cfg.scene.pool_size} must hold them "
            f"too)")
    if len(set(groups)) != len(groups):
        raise ValueError(f"groups must not repeat, got {list(groups)}")
    if isinstance(rounds, bool) or not isinstance(rounds, (int, np.integer)) or rounds < 1:
        raise ValueError(f"rounds must be a positive integer (rounds per group = parallel worlds), got {rounds!r}")
    return tuple(int(k) for k in groups)


class Evaluator:
    """Runs benchmark rounds for one config.  Build once; compiled once per policy (and batch
    size), reused for every group."""

    def __init__(self, cfg: Config, env: Optional[VagsEnv] = None):
        self.cfg = cfg
        self.env = env if env is not None else VagsEnv(cfg)
        self._compiled: dict[Any, Callable] = {}
        self._reset = jax.jit(self.env.step_reset)  # the same program as VagsEnv.reset
        self._reset_worlds = jax.jit(self.env.step_reset_worlds)
        self._start = np.asarray(cfg.camera.global_position, np.float32)

    def _rounds_impl(self, plan: Callable, params, key: jax.Array, s0: EnvState):
        """Plays B fresh rounds to their end: key (2,), s0 from ``VagsEnv.reset`` -> RoundOutcomes
        of (B,) arrays.  (The reset is its own compiled program, the same as ``VagsEnv.reset``'s, so
        that a persistent compilation cache can share it with training.)"""
        env, cfg = self.env, self.cfg
        g, tz = cfg.grasp, cfg.workspace.table_z
        B = s0.n_worlds
        extra = cfg.benchmark.max_attempts_extra
        budget = jnp.max(env.max_attempts(s0.sim.n_objects, extra))
        T = 2 * cfg.scene.max_objects + extra  # the largest budget any round can have
        noise = cfg.camera.noise.enabled

        def cond(c: _Carry):
            return (~c.done.all()) & (c.t < budget)

        def body(c: _Carry):
            key, k_act, k_obs = jax.random.split(c.key, 3)
            attempt = plan(params, k_act, env, c.env)
            s2, res = env.step_attempt(c.env, attempt, k_obs if noise else None)
            # Finished worlds keep their state: their outcome is ignored.
            keep = c.done
            s2 = where_worlds(keep, c.env, s2)
            position = attempt.position
            lifted = jnp.stack([position[:, 0], position[:, 1],
                                jnp.maximum(position[:, 2], tz + g.min_height_above_table) + g.lift_height], 1)
            back = jnp.linalg.norm(lifted - self._start, axis=1)
            ret = c.return_travel + jnp.where(keep | res.success, 0.0, back)
            pixel = camera.world_xy_to_pixel(position[:, :2], cfg.workspace)
            inside = camera.in_workspace(pixel, cfg.workspace)
            pixel = jnp.clip(pixel, 0, cfg.workspace.heightmap_px - 1)
            aimed = inside & (c.env.height[jnp.arange(B), pixel[:, 0], pixel[:, 1]] > cfg.exploration.height_threshold)
            on_obj = c.on_object + (aimed & ~keep).astype(jnp.int32)
            views = c.viewpoints + ((attempt.motions > 1) & ~keep).astype(jnp.int32)
            scores = c.scores
            if attempt.score is not None:
                score = jnp.where(keep, jnp.nan, attempt.score.astype(jnp.float32))
                scores = scores.at[:, jnp.minimum(c.t, T - 1)].set(score)
            done = keep | env.round_over(s2, extra) | s2.sim.error
            return _Carry(env=s2, done=done, return_travel=ret, on_object=on_obj, viewpoints=views,
                          scores=scores, key=key, t=c.t + 1)

        zi = jnp.zeros((B,), jnp.int32)
        c0 = _Carry(env=s0, done=env.round_over(s0, extra) | s0.sim.error,
                    return_travel=jnp.zeros((B,), jnp.float32), on_object=zi, viewpoints=zi,
                    scores=jnp.full((B, T), jnp.nan, jnp.float32), key=key, t=jnp.zeros((), jnp.int32))
        c = jax.lax.while_loop(cond, body, c0)
        s = c.env
        out = RoundOutcomes(
            n_objects=s.sim.n_objects, attempts=s.attempts, successes=s.successes, motions=s.motions,
            travel=s.travel, return_travel=c.return_travel, remaining=env.n_remaining(s), on_object=c.on_object,
            viewpoints=c.viewpoints, error=s.sim.error, overflow=s.sim.overflow, scores=c.scores)
        return out

    def run_group(self, policy: Policy, key, n_objects: int, rounds: int) -> RoundOutcomes:
        """``rounds`` parallel rounds of ``n_objects`` objects -> RoundOutcomes of numpy (rounds,)."""
        check_groups([n_objects], self.cfg, rounds)
        key = jnp.asarray(key)
        if jnp.issubdtype(key.dtype, jax.dtypes.prng_key):
            key = jax.random.key_data(key)
        k_reset, k_loop = jax.random.split(key)
        self.env.prepare(rounds)
        s0 = self._reset(k_reset, jnp.full((rounds,), n_objects, jnp.int32))  # errors: counted, not raised
        out = self.play(policy, k_loop, s0)
        _warn_failures(out, f"{rounds} rounds with {n_objects} objects")
        return out

    def run_groups(self, policy: Policy, seed: int, groups: Sequence[int], rounds: int) -> list[RoundOutcomes]:
        """Every group's ``rounds`` rounds in ONE batch of len(groups) * rounds worlds -> one
        RoundOutcomes of numpy (rounds,) per group.  Group k's scenes are those of
        ``run_group(policy, fold_in(PRNGKey(seed), k), k, rounds)``."""
        groups = check_groups(groups, self.cfg, rounds)
        s0, k_loop = self.reset_groups(seed, groups, rounds, rounds)
        out = self.play(policy, k_loop, s0)
        _warn_failures(out, f"{s0.n_worlds} rounds")
        return [jax.tree.map(lambda x: x[i * rounds:(i + 1) * rounds], out) for i in range(len(groups))]

    def reset_groups(self, seed: int, groups: Sequence[int], rounds: int, first: int):
        """The first ``first`` of the ``rounds`` scenes of each group (``run_groups``'s scenes:
        group k's per-round keys come from ``fold_in(PRNGKey(seed), k)``), in one batch ->
        (EnvState of len(groups) * first worlds, the key of the rounds' play)."""
        base = jax.random.PRNGKey(seed)
        keys, counts = [], []
        for k in groups:
            k_reset, _ = jax.random.split(jax.random.fold_in(base, k))
            k_sim, _ = jax.random.split(k_reset)
            keys.append(jax.random.split(k_sim, rounds)[:first])
            counts.append(jnp.full((first,), k, jnp.int32))
        self.env.prepare(first * len(groups))
        k_obs, k_loop = jax.random.split(jax.random.fold_in(base, 1 << 20))
        return self._reset_worlds(jnp.concatenate(keys), jnp.concatenate(counts), k_obs), k_loop

    def play(self, policy: Policy, key, state: EnvState) -> RoundOutcomes:
        """Plays the rounds of ``state`` (B worlds with fresh counters: from ``VagsEnv.reset``, or
        a scripted scene) to their end with ``policy`` -> RoundOutcomes of numpy (B,).  key: (2,)."""
        key = jnp.asarray(key)
        if jnp.issubdtype(key.dtype, jax.dtypes.prng_key):
            key = jax.random.key_data(key)
        self.env.prepare(state.n_worlds)
        fn = self._compiled.get(policy.plan)
        if fn is None:
            fn = self._compiled[policy.plan] = jax.jit(lambda p, k, s: self._rounds_impl(policy.plan, p, k, s))
        return jax.tree.map(np.asarray, jax.device_get(fn(policy.params, key, state)))


def _warn_failures(out: RoundOutcomes, what: str) -> None:
    if out.error.any() or out.overflow.any():
        warnings.warn(
            f"evaluate: {int(out.error.sum())} of {what} ended in a physics error and {int(out.overflow.sum())} "
            f"overflowed a contact buffer (see vags_jax.sim.simulator); they count as not cleared (raise "
            f"Config.sim.naconmax / njmax for overflows)", RuntimeWarning, stacklevel=3)


def evaluate(cfg: Config, policy: Policy, groups: Optional[Sequence[int]] = None,
             rounds: Optional[int] = None, seed: Optional[int] = None,
             time_model: Optional[MotionTimeModel] = None, evaluator: Optional[Evaluator] = None,
             log: Optional[Callable[[str], None]] = None, batch_groups: bool = True) -> dict:
    """The whole benchmark -> report dict (JSON-ready).

    ``groups``, ``rounds`` and ``time_model`` default to the config's ``benchmark`` section
    (``config.benchmark_groups``, ``benchmark.rounds``, ``MotionTimeModel.from_config``).
    Keys: ``policy``, ``seed``, ``rounds``, ``groups``, ``time_model``, ``groups_metrics``
    (list of ``summarize`` dicts with ``n_objects``, and ``wall_s`` when groups play one
    after the other), ``overall`` (pooled), ``outcomes`` ({k: RoundOutcomes.to_json()}),
    ``wall_s``.  ``seed`` defaults to ``cfg.seed``.  ``batch_groups``: every group in one batch
    (``Evaluator.run_groups``), else one batch per group (``run_group``).
    """
    groups = benchmark_groups(cfg) if groups is None else groups
    rounds = cfg.benchmark.rounds if rounds is None else rounds
    time_model = MotionTimeModel.from_config(cfg) if time_model is None else time_model
    groups = check_groups(groups, cfg, rounds)
    seed = cfg.seed if seed is None else int(seed)
    ev = evaluator if evaluator is not None else Evaluator(cfg)
    if ev.cfg != cfg:
        raise ValueError("evaluate: the evaluator was built for a different config")
    base = jax.random.PRNGKey(seed)
    per_group, parts, raw = [], [], {}
    t_all = time.time()
    batched = ev.run_groups(policy, seed, groups, rounds) if batch_groups else None
    for i, k in enumerate(groups):
        t0 = time.time()
        out = batched[i] if batched is not None else ev.run_group(policy, jax.random.fold_in(base, k), k, rounds)
        m = {"n_objects": k, **summarize(out, time_model)}
        if batched is None:
            m["wall_s"] = round(time.time() - t0, 2)
        per_group.append(m)
        parts.append(out)
        raw[str(k)] = out.to_json()
        if log is not None:
            log(f"group {k}: {m['successes']}/{m['attempts']} grasps, {m['rounds']} rounds"
                + (f", {m['wall_s']} s" if "wall_s" in m else ""))
    overall = summarize(RoundOutcomes.concatenate(parts), time_model)
    return {
        "policy": policy.name, "seed": seed, "rounds": rounds, "groups": list(groups),
        "max_attempts": f"2 * objects + {cfg.benchmark.max_attempts_extra}",
        "time_model": dataclasses.asdict(time_model),
        "groups_metrics": per_group, "overall": overall, "outcomes": raw,
        "wall_s": round(time.time() - t_all, 2), "batch_groups": bool(batch_groups),
    }


# ----------------------------------------------------------------------------- report


def _pct(x) -> str:
    return "-" if x is None else f"{100 * x:.1f}"


def _num(x, fmt="{:.2f}") -> str:
    return "-" if x is None else fmt.format(x)


def format_table(report: dict) -> str:
    """Markdown table: one row per group and one for the pooled overall."""
    head = ("| objects | rounds | attempts | successes | grasp success % | clearing % | motion number "
            "| picks/hour | viewpoint % | attempts/round | on object % | lost | errors |")
    rows = [head, "|" + "|".join(["---:"] * (head.count("|") - 1)) + "|"]

    def row(name, m):
        return (f"| {name} | {m['rounds']} | {m['attempts']} | {m['successes']} | "
                f"{_pct(m['grasp_success_rate'])} | {_pct(m['clearing_rate'])} | {_num(m['motion_number'])} | "
                f"{_num(m['picks_per_hour'], '{:.0f}')} | {_pct(m.get('viewpoint_rate'))} | "
                f"{_num(m['attempts_per_round'], '{:.1f}')} | "
                f"{_pct(m['on_object_rate'])} | {m['objects_lost']} | {m['physics_errors']} |")

    for m in report["groups_metrics"]:
        rows.append(row(str(m["n_objects"]), m))
    rows.append(row("**overall**", report["overall"]))
    return "\n".join(rows)


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


__all__ = [
    "POLICIES", "DEFAULT_GROUPS", "DEFAULT_ROUNDS", "MotionTimeModel", "RoundOutcomes", "Policy", "Evaluator",
    "heightmap_policy", "ggcnn_plan", "vags_plan", "vags_params",
    "summarize", "make_policy", "random_act", "highest_act", "heuristic_act", "gdnet_act", "min_width_grasp",
    "load_gdnet", "check_groups", "evaluate", "format_table", "save_report",
]
