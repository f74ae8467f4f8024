"""Benchmark policies: the ``Policy`` interface, scripted baselines and learned policies.

A policy plans one attempt per world, ``plan(params, key, env, EnvState) -> env.Attempt`` (grasp
pose, where its approach starts, motions), pure and jittable.  All but the GG-CNN ones choose
an action ``(B, 3) int32 [rotation, row, col]`` on the global heightmaps (1 motion):

* ``gdnet``: greedy argmax of GDNet's Q over (rotation, row, col) -- no exploration.  Its
  ``params`` are the online ``{"params", "batch_stats"}`` of a stage-1 checkpoint.
* ``random``: a uniformly random object pixel (height > ``exploration.height_threshold``;
  any pixel when none) and a uniformly random rotation.  Sanity floor.
* ``highest``: the highest point of the height map (box-smoothed over ~3 cm so that the middle
  of a flat top beats its edges and single tall pixels), rotation 0.  The simplest scripted grasp.
* ``heuristic``: scripted minimum-width grasp.  Take the ``highest`` point; for each of the
  ``grasp.n_axes`` distinct closing axes, walk the height map outwards from it along the
  axis and measure the contiguous run of cells that would stand between the open fingers at
  grasp depth (height > surface - ``depth_below_surface``, and an object cell); choose the axis
  with the narrowest run that fits in ``finger_stroke`` (the narrowest one if none fits), and
  move the grasp centre to the middle of that run.
* ``vags``: the method (``vags_plan``, ``vags_jax.policies.decision``): where the gate's score
  is above the threshold, grasp directly at GDNet's argmax (1 motion); else move the camera to
  VANet's argmax viewpoint and grasp with the close-view planner (2 motions).  ``params`` =
  ``{"gdnet", "vanet", "success", "ggcnn", "threshold"}`` (``rundir.load_vags``); the
  threshold is an argument of the compiled loop, so a threshold sweep compiles once.  A
  threshold of -inf is the VANet ablation (GDNet alone, ``eval.py --no-viewpoint``).
* ``ggcnn``: GG-CNN on the raw depth image of the global camera, 1 motion (the paper's GG-CNN
  baseline).  ``ggcnn-close``: move the camera 25 cm above the ``highest`` cell, take a depth
  image there and grasp at GG-CNN's best grasp, 2 motions.  Both need a GG-CNN trained by
  ``train.py --stage ggcnn``.
* ``nbv``: the next-best-view baseline: the small viewpoint network of ``train.py --stage nbv``
  (``nets.nbv_net``) on the global maps, ALWAYS a move to its argmax viewpoint, then the
  close-view planner's grasp (``vags.local_planner``), 2 motions.  params = ``{"vanet", "gdnet",
  "ggcnn"}`` (``rundir.load_nbv``).
* ``mvp``: Multi-View Picking (``vags_jax.policies.mvp``): GG-CNN on a descending sequence of
  views fused in a grid, 1 + the camera moves motions; its failure map is the policy's memory
  over a round.  Needs a GG-CNN.
* ``vpg``: the VPG baseline (``vags_jax.policies.vpg``): the argmax over its push and grasp Q
  maps on the global view; a push is one motion and no grasp attempt.  ``params`` = VPGNet's
  ``{"params", "batch_stats"}`` from ``train.py --stage vpg`` (``stages.vpg.load_vpg``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Optional

import jax
import jax.numpy as jnp
import numpy as np

from vags_jax.batching import map_in_groups
from vags_jax.config import Config
from vags_jax.env import Attempt, EnvState, VagsEnv
from vags_jax.ggcnn.planner import predict_grasp
from vags_jax.nets import make_qnet, nbv_net
from vags_jax.nets.ggcnn import GGCNN
from vags_jax.policies.decision import VagsNets, close_view_grasp, direct_grasp, gate_threshold, greedy
from vags_jax.policies.mvp import MvpPlanner
from vags_jax.policies.vpg import vpg_plan

POLICIES = ("vags", "gdnet", "ggcnn", "ggcnn-close", "mvp", "nbv", "vpg", "random", "highest", "heuristic")
# The policies that need a GG-CNN trained by ``train.py --stage ggcnn``.
GGCNN_POLICIES = ("ggcnn", "ggcnn-close", "mvp")


@dataclass(frozen=True)
class Policy:
    """A grasping policy for the benchmark.

    plan: ``(params, key, env: VagsEnv, state: EnvState) -> Attempt``, pure and jittable: per
    world, the grasp (world position, yaw), where its approach starts and how many motions the
    attempt takes (``vags_jax.env.Attempt``: a grasp planned on the global view is 1 motion, one
    after a viewpoint move 2).  ``params``: a pytree passed to the compiled loop as an argument
    (network weights), or None.  ``act``: for policies that choose a heightmap action on the
    global view, ``(params, key, state) -> action (B, 3) int32 [rotation, row, col]`` (``plan``
    executes it, 1 motion); None for the others.  ``pushes``: the plan's attempts may push
    (``Attempt.push``; VPG), which the benchmark then executes and counts.

    A policy with a memory over the attempts of a round (MVP's failure map) gives
    ``init_memory(B) -> pytree`` and ``remember(memory, attempt, success (B,) bool) -> memory``
    (run after every attempt); its ``plan`` then takes the memory as a fifth argument.
    """

    name: str
    plan: Callable
    params: Any = None
    act: Optional[Callable] = None
    init_memory: Optional[Callable] = None
    remember: Optional[Callable] = None
    pushes: bool = False


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
    nets = VagsNets(cfg)

    def plan(params, key, env: VagsEnv, state: EnvState) -> Attempt:
        return nets.plan(params, key, env, state)[0]

    return plan


def nbv_plan(cfg: Config) -> Callable:
    """The NBV baseline: the viewpoint network's argmax on the global maps, always moved to, then
    the close-view planner's grasp there (``decision.close_view_grasp``, 2 motions)."""
    view_net = make_qnet(nbv_net(cfg.net), "vanet")
    nets = VagsNets(cfg)

    def plan(params, key, env: VagsEnv, state: EnvState) -> Attempt:
        q_view = nets.q_fn(view_net, params["vanet"])(state.color, state.height)  # (B, H, W)
        view, _ = greedy(q_view)
        gdnet_q = nets.gdnet_q(params["gdnet"]) if cfg.vags.local_planner == "gdnet" else None
        return close_view_grasp(cfg, env, state, view, key, gdnet_q, params.get("ggcnn"), nets.ggcnn)[0]

    return plan


def nbv_params(networks, cfg: Config) -> dict:
    """The ``nbv`` policy's params from ``rundir.load_nbv``; ValueError when the close-view
    planner needs a GG-CNN the run lacks."""
    if cfg.vags.local_planner == "ggcnn" and networks.ggcnn is None:
        raise ValueError("vags.local_planner=ggcnn needs a GG-CNN in the run (RUN/ggcnn): train one with "
                         "python train.py --stage ggcnn --out RUN")
    params = {"vanet": networks.vanet, "gdnet": networks.gdnet}
    if networks.ggcnn is not None:
        params["ggcnn"] = networks.ggcnn
    return params


def vags_params(networks, cfg: Config, threshold=None) -> dict:
    """The ``vags`` policy's params from ``pipeline.VagsNetworks``: the gate's threshold is the
    run's ("q" gate) or ``-vags.move_cost`` ("success" gate), unless ``threshold`` overrides it
    (e.g. ``-inf`` for the VANet ablation, which needs no "rate" table); with the "gdnet" planner
    ``"close_gdnet"`` is the GDNet of the grasps after a move (``networks.close_gdnet``, else
    GDNet).  ValueError when the config's gate or close-view planner needs a network the run lacks."""
    if cfg.vags.gate in ("success", "rate") and networks.success is None:
        raise ValueError(f"the run's networks ({networks.source}) have no success net (trained before the "
                         f"'success' gate): evaluate with --set vags.gate=q, or train the run again")
    ablation = threshold is not None and float(threshold) == -math.inf  # GDNet alone: the gate never moves
    if cfg.vags.gate == "rate" and networks.gate_table is None and not ablation:
        raise ValueError(f"vags.gate=rate needs a gate table measured on the run's networks ({networks.source}) "
                         f"in RUN/gate.json, and the run has none for them: measure it with "
                         f"python -m vags_jax.stages.gate_measure --run RUN (it measures the run's latest "
                         f"networks), or evaluate with --set vags.gate=success")
    # Settings the table was measured under, which the decision must share: (vags field, the
    # table's value, how to get a table for the config's value instead).
    measure = "python -m vags_jax.stages.gate_measure --run RUN"
    for field, was, other in (
            ("gate_estimate", getattr(networks, "gate_estimate", "grasp"),
             f"fit the table on the other estimate with {measure} --refit --bins K --estimate {cfg.vags.gate_estimate}"),
            ("close_score", getattr(networks, "gate_close_score", "q"),
             f"measure a table for this one with {measure} --close-score {cfg.vags.close_score}"),
            ("direct_score", getattr(networks, "gate_direct_score", "q"),
             f"measure a table for this one with {measure} --direct-score {cfg.vags.direct_score}")):
        now = getattr(cfg.vags, field)
        if cfg.vags.gate == "rate" and networks.gate_table is not None and not ablation and was != now:
            raise ValueError(f"the run's gate table (RUN/gate.json) was measured with vags.{field}={was!r}, and this "
                             f"config has {now!r}: evaluate with --set vags.{field}={was}, or {other}")
    if cfg.vags.close_score == "success" and networks.success is None:
        raise ValueError(f"vags.close_score=success scores the grasps after a move with the success net, and the "
                         f"run's networks ({networks.source}) have none: evaluate with --set vags.close_score=q")
    if cfg.vags.direct_score == "success" and networks.success is None:
        raise ValueError(f"vags.direct_score=success plans the direct grasps with the success net, and the run's "
                         f"networks ({networks.source}) have none: evaluate with --set vags.direct_score=q")
    if cfg.vags.local_planner == "ggcnn" and networks.ggcnn is None:
        raise ValueError("vags.local_planner=ggcnn needs a GG-CNN in the run (RUN/ggcnn): train one with "
                         "python train.py --stage ggcnn --out RUN")
    if cfg.vags.gate == "success" and cfg.vags.view_estimate == "mean" and (
            networks.calibration is None or networks.calibration.shape[0] < 3):
        raise ValueError(f"the run's networks ({networks.source}) keep no mean success after a move (trained "
                         f"before vags.view_estimate=mean): evaluate with --set vags.view_estimate=vanet")
    thr = gate_threshold(cfg.vags, networks.q_threshold) if threshold is None else threshold
    # device_put of a float32 array: no convert_element_type program (eval.py's bad-input checks compile nothing).
    params = {"gdnet": networks.gdnet, "vanet": networks.vanet,
              "threshold": jax.device_put(np.asarray(thr, np.float32))}
    if networks.ggcnn is not None:
        params["ggcnn"] = networks.ggcnn
    if cfg.vags.local_planner == "gdnet":  # always present: every pick of GDNets runs one compiled program
        close = getattr(networks, "close_gdnet", None)
        params["close_gdnet"] = networks.gdnet if close is None else close
    if networks.success is not None:
        params["success"] = networks.success
    if networks.calibration is not None:
        params["calibration"] = networks.calibration
    if cfg.vags.gate == "rate":  # the ablation without a table: one bin whose move value is 0
        table = np.array([[np.inf], [0.0]], np.float32) if networks.gate_table is None else networks.gate_table
        params["gate_table"] = jax.device_put(np.asarray(table, np.float32))
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

    Returns ``action (B, 3) int32 [rotation, row, col]`` (rotation in 0..grasp.n_axes - 1) and
    ``width (B,) float32``: the measured extent (m) between the fingers along the chosen axis.
    """
    ws, g = cfg.workspace, cfg.grasp
    b, h, w = height.shape
    px = ws.pixel_size
    centre = _highest_pixel(height, cfg)  # (B, 2)
    bi = jnp.arange(b)
    surface = height[bi, centre[:, 0], centre[:, 1]]
    level = jnp.maximum(surface - g.depth_below_surface, cfg.exploration.height_threshold)  # (B,)

    n_axes = g.n_axes
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


GDNET_ALONE_SCORES = ("q", "q_mean")  # the vags.direct_score values GDNet alone can plan by


def gdnet_act(cfg: Config) -> Callable:
    """Greedy GDNet: params = {"params", "batch_stats"} of the online network, run over the
    worlds in groups of ``net.forward_batch`` (the rotations of hundreds of worlds at once need
    tens of GB), as VAGS's networks are; its grasp is ``decision.direct_grasp``'s under
    ``vags.direct_score`` "q" (the argmax) or "q_mean" (the argmax of its half-turn mean)."""
    if cfg.vags.direct_score not in GDNET_ALONE_SCORES:
        raise ValueError(f"the gdnet policy plans with GDNet alone, and vags.direct_score="
                         f"{cfg.vags.direct_score} needs the success net of a VAGS run: use one of "
                         f"{', '.join(GDNET_ALONE_SCORES)}, or --policy vags --no-viewpoint on a run with stage 2")
    net = make_qnet(cfg.net, "gdnet")

    def act(params, key, state: EnvState):
        del key
        q = map_in_groups(lambda c, h: net.apply(params, c, h, False), (state.color, state.height),
                          cfg.net.forward_batch)  # (B, R, H, W)
        return direct_grasp(q, None, cfg.vags.direct_score, cfg.grasp.half_turn)[0]

    return act


def make_policy(name: str, cfg: Config, gdnet_variables: Any = None, ggcnn_params: Any = None,
                vags_networks: Any = None, threshold: Optional[float] = None,
                vpg_variables: Any = None) -> Policy:
    """Policy by name (``POLICIES``); ``gdnet`` needs ``gdnet_variables`` ({"params",
    "batch_stats"}, e.g. from ``load_gdnet``); ``ggcnn`` / ``ggcnn-close`` need
    ``ggcnn_params`` ({"params"}, e.g. from ``ggcnn_stage.load_ggcnn``); ``vags`` needs
    ``vags_networks`` (``pipeline.load_vags``) and takes ``threshold`` (default: the run's);
    ``vpg`` needs ``vpg_variables`` (``stages.vpg.load_vpg``)."""
    if name not in POLICIES:
        raise ValueError(f"unknown policy {name!r}; choose one of {', '.join(POLICIES)}")
    if name == "vags":
        if vags_networks is None:
            raise ValueError("policy 'vags' needs the trained networks of a run (eval.py --run RUN after "
                             "train.py's stage 2 or 3), or pass vags_networks")
        return Policy("vags", vags_plan(cfg), vags_params(vags_networks, cfg, threshold))
    if name == "nbv":
        if vags_networks is None:
            raise ValueError("policy 'nbv' needs the NBV network of a run (train.py --stage nbv --out RUN, then "
                             "eval.py --run RUN --policy nbv), or pass vags_networks (rundir.load_nbv)")
        return Policy("nbv", nbv_plan(cfg), nbv_params(vags_networks, cfg))
    if name == "vpg":
        if vpg_variables is None:
            raise ValueError("policy 'vpg' needs VPG's trained networks: evaluate a run with train.py --stage vpg "
                             "(eval.py --run RUN --policy vpg) or pass vpg_variables")
        return Policy("vpg", vpg_plan(cfg), vpg_variables, pushes=True)
    if name == "gdnet":
        if gdnet_variables is None:
            raise ValueError("policy 'gdnet' needs trained GDNet variables: evaluate a run "
                             "directory (eval.py --run RUN) or pass gdnet_variables")
        return heightmap_policy("gdnet", gdnet_act(cfg), gdnet_variables)
    if name in GGCNN_POLICIES:
        if ggcnn_params is None:
            raise ValueError(f"policy {name!r} needs trained GG-CNN parameters: evaluate a run with a GG-CNN "
                             f"(train.py --stage ggcnn --out RUN, then eval.py --run RUN) or pass ggcnn_params")
        if name == "mvp":
            mvp = MvpPlanner(cfg)
            return Policy(name, mvp.plan, ggcnn_params, init_memory=mvp.init_memory, remember=mvp.remember)
        return Policy(name, ggcnn_plan(cfg, close=name == "ggcnn-close"), ggcnn_params)
    return heightmap_policy(name, {"random": random_act, "highest": highest_act, "heuristic": heuristic_act}[name](cfg))
