"""VAGS's decision (paper Fig. 2): grasp directly, or move the camera first; and the grasp after
the move.  Shared by training (stages 2 and 3) and evaluation (``eval.py --policy vags``).

At the global view GDNet gives grasp Q values ``(B, R, H, W)``, VANet viewpoint Q values
``(B, H, W)`` and the success net (GDNet's architecture, trained with gamma 0) an estimate of
each grasp's success ``(B, R, H, W)``.  Per world the *gate* (``config.Vags.gate``) scores the
state and the world grasps directly where the score exceeds the threshold:

* ``"q"`` (the paper): score = GDNet's largest Q, threshold = the calibrated Q threshold;
* ``"success"``: score = p_direct - p_view, threshold = ``-vags.move_cost``, where p_direct is
  the success net at GDNet's argmax and p_view the expected success of the grasp after a move
  (``vags.view_estimate``: "mean", the running mean of that success over the run's greedy
  moves; "vanet", VANet's largest Q, VANet trained with gamma 0 on that success): move when a
  move is expected to add more than ``move_cost`` of success;
* ``"rate"``: score = minus the value of a move in p_direct's bin of the run's measured table
  (``rate_gate``; RUN/gate.json), threshold 0: move where a move raises the picks per hour.

A direct grasp is GDNet's argmax, or the argmax of the success net's half-turn mean over the
global maps (``vags.direct_score="success"``) (1 motion).  Otherwise the camera moves to the viewpoint
above VANet's argmax cell (or GDNet's: ``vags.viewpoint``; ``camera.viewpoint_pose``), takes the raw depth image there, and
grasps with the close-view planner (``vags.local_planner``): ``"gdnet"``, the argmax on the
global maps fused with the close view (``view_fusion``) among the cells the close view saw, of
GDNet's Q or of the success net's half-turn mean (``vags.close_score``); ``"ggcnn"``, GG-CNN's
best grasp in the close image.  2 motions.  A threshold of ``-inf``
always grasps directly (the VANet ablation); ``+inf`` always moves.
"""
from __future__ import annotations

from typing import Any, Callable, Optional

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from vags_jax import batching
from vags_jax.perception import view_fusion
from vags_jax.config import Config, Vags
from vags_jax.config.sections import VAGS_CLOSE_SCORES as CLOSE_SCORES
from vags_jax.config.sections import VAGS_DIRECT_SCORES as DIRECT_SCORES
from vags_jax.config.sections import VAGS_GATE_ESTIMATES as GATE_ESTIMATES
from vags_jax.ggcnn.planner import predict_grasp
from vags_jax.policies import rate_gate
from vags_jax.nets import make_qnet
from vags_jax.nets.ggcnn import GGCNN
from vags_jax.env import CameraImage, EnvState, VagsEnv, select_attempt


@struct.dataclass
class Decision:
    """Per world (B worlds): direct (B,) bool, grasp directly; grasp (B, 3) int32 GDNet's
    argmax [rotation, row, col]; view (B, 2) int32 VANet's argmax [row, col]; q_max (B,)
    float32 the largest GDNet Q; score (B,) float32 the gate's score (``gate_score``)."""

    direct: jax.Array
    grasp: jax.Array
    view: jax.Array
    q_max: jax.Array
    score: jax.Array


@struct.dataclass
class CloseView:
    """What the move to a viewpoint produced, per world (B worlds): image (``CameraImage``, the
    close RGB-D image); color (B, H, W, 3) / height (B, H, W) the fused maps and seen (B, H, W)
    the cells the close image saw ("gdnet" planner; the global maps for "ggcnn"); action (B, 3)
    int32 GDNet's [rotation, row, col] on the fused maps ("gdnet"; zeros for "ggcnn");
    image_grasp GG-CNN's ``ImageGrasp`` ("ggcnn"; None for "gdnet")."""

    image: CameraImage
    color: jax.Array
    height: jax.Array
    seen: jax.Array
    action: jax.Array
    image_grasp: Any = None


def greedy(q: jax.Array):
    """q (B, ...) -> (argmax indices (B, q.ndim - 1) int32, max (B,) float32) over all but B."""
    b = q.shape[0]
    flat = q.reshape(b, -1)
    best = jnp.argmax(flat, axis=1)
    q_max = jnp.take_along_axis(flat, best[:, None], axis=1)[:, 0].astype(jnp.float32)
    return jnp.stack(jnp.unravel_index(best, q.shape[1:]), axis=-1).astype(jnp.int32), q_max


def value_at(q: jax.Array, action: jax.Array) -> jax.Array:
    """q (B, R, H, W) at action (B, 3) [rotation, row, col] -> (B,) float32."""
    b = jnp.arange(q.shape[0])
    return q[b, action[:, 0], action[:, 1], action[:, 2]].astype(jnp.float32)


def _symmetric_rotation(q: jax.Array, grasp: jax.Array, half_turn: bool = False) -> jax.Array:
    """(B,) int32 the rotation of the same parallel-jaw grasp turned half a turn: (r + R/2) % R;
    with ``half_turn`` (rotations over half a turn, ``config.Grasp``) none repeats it: r itself."""
    if half_turn:
        return grasp[:, 0]
    n_rot = q.shape[1]
    if n_rot % 2:
        raise ValueError(f"a symmetric success estimate needs an even number of grasp rotations (the grasp "
                         f"turned half a turn is one of them), got {n_rot}: use vags.gate_estimate=grasp")
    return (grasp[:, 0] + n_rot // 2) % n_rot


def half_turn_mean(q: jax.Array, setting: str = "close_score", half_turn: bool = False) -> jax.Array:
    """q (B, R, H, W) -> (B, R, H, W) float32: at rotation r the mean of q at r and r + R/2 (a
    parallel-jaw grasp and the same grasp turned half a turn, which the network sees on
    heightmaps rotated 180 degrees apart); averaging lowers the noise an argmax picks up.
    setting: the ``vags`` field that asked for it, named in the error of an odd R.  With
    ``half_turn`` (rotations over half a turn) the network sees each grasp once: q itself."""
    if half_turn:
        return q.astype(jnp.float32)
    n_rot = q.shape[1]
    if n_rot % 2:
        raise ValueError(f"the half-turn mean needs an even number of grasp rotations (the grasp turned half a "
                         f"turn is one of them), got {n_rot}: use vags.{setting}=q")
    q = q.astype(jnp.float32)
    return 0.5 * (q + jnp.roll(q, n_rot // 2, axis=1))


def _window_mean(q: jax.Array, rotation: jax.Array, row: jax.Array, col: jax.Array, radius: int) -> jax.Array:
    """The mean of q (B, R, H, W) at ``rotation`` (B,) over the cells within ``radius`` of
    (row, col) (B,) each, cells off the map left out -> (B,) float32."""
    b, _, h, w = q.shape
    qr = q[jnp.arange(b), rotation].astype(jnp.float32)  # (B, H, W)
    rows, cols = jnp.arange(h)[None, :, None], jnp.arange(w)[None, None, :]
    near = (jnp.abs(rows - row[:, None, None]) <= radius) & (jnp.abs(cols - col[:, None, None]) <= radius)
    return jnp.where(near, qr, 0.0).sum(axis=(1, 2)) / near.sum(axis=(1, 2))


def success_estimate(q_success: jax.Array, grasp: jax.Array, estimate: str = "grasp",
                     half_turn: bool = False) -> jax.Array:
    """The success net's estimate (B,) float32 of grasp (B, 3) [rotation, row, col] from its map
    q_success (B, R, H, W) (``config.Vags.gate_estimate``): "grasp", its value at the grasp;
    "symmetric", the mean with the value at the grasp turned half a turn (the same grasp of a
    parallel-jaw gripper, seen by the network on a heightmap rotated 180 degrees more);
    "window", the mean over both rotations and the 3 x 3 cells around the grasp.  With
    ``half_turn`` (rotations over half a turn) "symmetric" is "grasp" and "window" the mean over
    the grasp's own rotation: the network sees each grasp once."""
    if estimate == "grasp":
        return value_at(q_success, grasp)
    flipped = _symmetric_rotation(q_success, grasp, half_turn)
    if estimate == "symmetric":
        return 0.5 * (value_at(q_success, grasp) + value_at(q_success, grasp.at[:, 0].set(flipped)))
    if estimate == "window":
        row, col = grasp[:, 1], grasp[:, 2]
        return 0.5 * (_window_mean(q_success, grasp[:, 0], row, col, 1) + _window_mean(q_success, flipped, row, col, 1))
    raise ValueError(f"unknown success estimate {estimate!r}: one of {GATE_ESTIMATES}")


def success_estimates(q_success: jax.Array, q_grasp: jax.Array, grasp: jax.Array, half_turn: bool = False) -> dict:
    """Every estimate of grasp (B, 3) for analysis (``stages.gate_measure`` records them):
    ``p_<estimate>`` for each of ``GATE_ESTIMATES`` (``success_estimate``), ``p_best`` the
    success net's largest value anywhere (B,), ``q_direct`` GDNet's Q (B,) at the grasp, from
    q_success / q_grasp (B, R, H, W); ``half_turn``: ``success_estimate``'s."""
    out = {f"p_{e}": success_estimate(q_success, grasp, e, half_turn) for e in GATE_ESTIMATES}
    out["p_best"] = jnp.max(q_success.reshape(q_success.shape[0], -1), axis=1).astype(jnp.float32)
    out["q_direct"] = value_at(q_grasp, grasp)
    return out


NO_MOVE_SCORE = 1e-6  # the "rate" gate's smallest score where a move is worth nothing (above its threshold 0)


def gate_score(gate: str, q_max: jax.Array, p_direct: Optional[jax.Array], p_view: Optional[jax.Array],
               calibration: Optional[jax.Array] = None, view_estimate: str = "vanet",
               gate_table: Optional[jax.Array] = None):
    """The gate's score (B,): GDNet's largest Q ("q"), the calibrated p_direct - p_view
    ("success") or minus the measured value of a move at p_direct ("rate": gate_table (2, K),
    ``rate_gate.GateTable.array``).  calibration (2,) or (3,) [bias direct, bias view, mean success after a move]
    (``update_calibration``): each estimate's running bias (estimate minus outcome) is
    subtracted from it (None: no correction).  view_estimate "mean" replaces p_view by the
    third entry, the same for every world (``config.Vags.view_estimate``)."""
    if gate == "q":
        return q_max.astype(jnp.float32)
    if gate == "rate":
        if p_direct is None or gate_table is None:
            raise ValueError("the 'rate' gate needs the success net's estimate and the run's measured gate table "
                             "(python -m vags_jax.stages.gate_measure --run RUN)")
        value = rate_gate.move_value(jnp.asarray(gate_table, jnp.float32), p_direct).astype(jnp.float32)
        # The comparison with the threshold (0) is strict: a bin whose value is 0 (a move gains
        # nothing) scores above it, so the gate moves only where the value is positive, as the
        # table's own summaries (``rate_gate.moves_summary``) count its moves.
        return jnp.where(value > 0, -value, jnp.maximum(-value, NO_MOVE_SCORE))
    if p_direct is None or p_view is None:
        raise ValueError("the 'success' gate needs the success net's and VANet's estimates")
    cal = jnp.zeros((3,), jnp.float32) if calibration is None else jnp.asarray(calibration, jnp.float32)
    if view_estimate == "mean":
        if cal.shape[0] < 3:
            raise ValueError("vags.view_estimate='mean' needs the mean success after a move, which this "
                             "calibration (2 entries, an older run) lacks: use vags.view_estimate=vanet")
        view = jnp.broadcast_to(cal[2], jnp.shape(p_view))
    else:
        view = p_view - cal[1]
    return ((p_direct - cal[0]) - view).astype(jnp.float32)


def update_calibration(calibration: jax.Array, p_direct: jax.Array, p_view: jax.Array, success: jax.Array,
                       direct: jax.Array, view: jax.Array, decay: float) -> jax.Array:
    """The running calibration (3,) [bias direct, bias view, mean success after a move] after
    one iteration: p_direct, p_view (B,) the estimates, success (B,) bool the outcomes, direct /
    view (B,) bool the greedy attempts of each kind.  Each entry moves to ``decay * old + (1 -
    decay) * mean(x)`` over its attempts (x = p - success for the biases, success for the mean),
    and stays where it has none."""
    s = success.astype(jnp.float32)
    out = []
    for i, (x, m) in enumerate(((p_direct - s, direct), (p_view - s, view), (s, view))):
        n = m.sum()
        mean = jnp.where(m, x, 0.0).sum() / jnp.maximum(n, 1)
        out.append(jnp.where(n > 0, decay * calibration[i] + (1.0 - decay) * mean, calibration[i]))
    return jnp.stack(out).astype(jnp.float32)


def initial_calibration() -> jax.Array:
    """(3,) float32 at a stage's start: no bias; an optimistic mean success after a move of 1, so
    that a "mean" gate moves (and so measures that success) until the running mean says otherwise."""
    return jnp.array([0.0, 0.0, 1.0], jnp.float32)


def gate_threshold(vcfg: Vags, q_threshold) -> jax.Array:
    """The threshold the gate's score is compared with: the Q threshold ("q"), -move_cost
    ("success") or 0 ("rate": the table's move values already count the move's time)."""
    if vcfg.gate == "q":
        return jnp.asarray(q_threshold, jnp.float32)
    if vcfg.gate == "rate":
        return jnp.zeros((), jnp.float32)
    return jax.device_put(np.float32(-vcfg.move_cost))


def _check_maps(q_grasp, q_view) -> None:
    if q_grasp.ndim != 4:
        raise ValueError(f"decide: GDNet Q must be (B, R, H, W), got shape {tuple(q_grasp.shape)}")
    b, _, h, w = q_grasp.shape
    if tuple(q_view.shape) != (b, h, w):
        raise ValueError(f"decide: VANet Q must be (B, H, W) = ({b}, {h}, {w}) like GDNet's, got "
                         f"{tuple(q_view.shape)}")


def direct_grasp(q_grasp: jax.Array, q_success: Optional[jax.Array], direct_score: str = "q",
                 half_turn: bool = False):
    """The direct grasp from the global maps (``config.Vags.direct_score``) -> (grasp (B, 3)
    int32 [rotation, row, col], GDNet's largest Q (B,) float32): GDNet's argmax ("q"), the
    argmax of GDNet's own ``half_turn_mean`` ("q_mean"), or the argmax of q_success's
    ``half_turn_mean`` ("success"; q_success (B, R, H, W); ``half_turn``: the rotations span
    half a turn, ``config.Grasp.half_turn``)."""
    planned, q_max = greedy(q_grasp)
    if direct_score == "q":
        return planned, q_max
    if direct_score == "q_mean":
        return greedy(half_turn_mean(q_grasp, "direct_score", half_turn))[0], q_max
    if direct_score != "success":
        raise ValueError(f"unknown direct score {direct_score!r}: one of {DIRECT_SCORES}")
    if q_success is None:
        raise ValueError("vags.direct_score=success plans the direct grasp with the success net, and none was given")
    return greedy(half_turn_mean(q_success, "direct_score", half_turn))[0], q_max


def direct_value(q_grasp: jax.Array, q_success: Optional[jax.Array], grasp: jax.Array, direct_score: str = "q",
                 half_turn: bool = False) -> jax.Array:
    """(B,) float32 the value ``direct_grasp`` maximized at its grasp (B, 3): GDNet's Q ("q"), its
    half-turn mean ("q_mean") or the success net's ("success"); q maps (B, R, H, W)."""
    if direct_score == "success":
        return value_at(half_turn_mean(q_success, "direct_score", half_turn), grasp)
    if direct_score == "q_mean":
        return value_at(half_turn_mean(q_grasp, "direct_score", half_turn), grasp)
    return value_at(q_grasp, grasp)


def decide(q_grasp: jax.Array, q_view: jax.Array, threshold, q_success: Optional[jax.Array] = None,
           gate: str = "q", calibration: Optional[jax.Array] = None, view_estimate: str = "vanet",
           viewpoint: str = "vanet", gate_table: Optional[jax.Array] = None,
           gate_estimate: str = "grasp", direct_score: str = "q", half_turn: bool = False) -> Decision:
    """The decision on Q maps: q_grasp (B, R, H, W), q_view (B, H, W), threshold scalar (or
    (B,)), q_success (B, R, H, W), calibration (3,) and view_estimate for the "success" gate
    (``gate_score``), gate_table (2, K) for the "rate" gate; the direct grasp is
    ``direct_grasp``'s (``direct_score``), p_direct the success net's ``gate_estimate`` of it
    (``success_estimate``); grasp directly where the gate's score exceeds ``threshold``.  The
    view is VANet's argmax cell, or the direct grasp's with ``viewpoint="grasp"``
    (``config.Vags.viewpoint``).  half_turn: GDNet's rotations span half a turn
    (``config.Grasp.half_turn``; ``success_estimate``, ``half_turn_mean``)."""
    _check_maps(q_grasp, q_view)
    grasp, q_max = direct_grasp(q_grasp, q_success, direct_score, half_turn)
    view, v_max = greedy(q_view)
    if viewpoint == "grasp":
        view = grasp[:, 1:]
    p_direct = None if q_success is None else success_estimate(q_success, grasp, gate_estimate, half_turn)
    score = gate_score(gate, q_max, p_direct, v_max, calibration, view_estimate, gate_table)
    return Decision(direct=score > threshold, grasp=grasp, view=view, q_max=q_max, score=score)


def q_in_groups(one: Callable, group: int) -> Callable:
    """``one(color, height) -> maps`` -> ``(color, height, need=None) -> maps`` over the worlds in
    groups of ``group``: every world, or given ``need`` (B,) bool only the needed ones, the
    others' maps zeros (``batching.map_in_groups_where``)."""
    def q(color, height, need=None):
        if need is None:
            return batching.map_in_groups(one, (color, height), group)
        return batching.map_in_groups_where(one, (color, height), group, need)

    return q


def fused_grasp(color: jax.Array, height: jax.Array, depth: jax.Array, rgb: jax.Array, pose: jax.Array,
                cam_cfg, ws_cfg, gdnet_q: Callable, anywhere: bool = False, success_q: Optional[Callable] = None,
                need: Optional[jax.Array] = None, half_turn: bool = False):
    """The "gdnet" close-view planner's grasp: the close images depth (B, h, w) / rgb (B, h, w, 3)
    taken at pose (B, 4, 4) with camera cam_cfg, fused into the global maps color (B, H, W, 3) /
    height (B, H, W) (``view_fusion``), then the argmax among the cells the close view saw
    (anywhere if it saw none, or with ``anywhere``: ``vags.close_region="map"``) of GDNet's Q
    (gdnet_q), or, given success_q (``vags.close_score="success"``), of the success net's
    ``half_turn_mean`` -> (action (B, 3) int32 [rotation, row, col], the score maximized there
    (B,) float32, the fused color (B, H, W, 3) and height (B, H, W), seen (B, H, W) bool).
    gdnet_q / success_q: ``(color, height) -> (B, R, H, W)``; only the one scored is run.  need:
    (B,) bool, the worlds whose grasp is used: passed on as the scored callable's third argument
    (``VagsNets.q_fn``), which may leave the others' maps zeros (their actions are then meaningless).
    half_turn: the rotations span half a turn (``half_turn_mean``)."""
    color, height, seen = view_fusion.fuse_close_view(color, height, depth, rgb, pose, cam_cfg, ws_cfg)
    q_fn = gdnet_q if success_q is None else success_q
    q = q_fn(color, height) if need is None else q_fn(color, height, need)
    score = q if success_q is None else half_turn_mean(q, half_turn=half_turn)
    region = jnp.where(seen.any(axis=(1, 2), keepdims=True) & (not anywhere), seen, True)
    action, best = greedy(jnp.where(region[:, None], score, -jnp.inf))
    return action, best, color, height, seen


def close_view_grasp(cfg: Config, env: VagsEnv, state: EnvState, view: jax.Array, key,
                     gdnet_q: Optional[Callable] = None, ggcnn_params=None, ggcnn_model=None,
                     success_q: Optional[Callable] = None, need: Optional[jax.Array] = None):
    """Move the camera above view (B, 2) [row, col], take the close image (key: its sensor
    noise) and plan the grasp there with ``cfg.vags.local_planner`` -> (the attempt, 2 motions;
    ``CloseView``).  gdnet_q: ``(color, height) -> (B, R, H, W)`` GDNet's Q ("gdnet");
    success_q: the success net's, scored instead where given (``VagsNets.close_success_q``:
    ``vags.close_score="success"``); ggcnn_params / ggcnn_model: GG-CNN ("ggcnn"); need: (B,) bool,
    the worlds whose close grasp is used (``fused_grasp``), or None for all."""
    pose = env.viewpoint_pose(state, view)
    image = env.camera_image(state.sim, pose, key)
    B = state.n_worlds
    if cfg.vags.local_planner == "gdnet":
        if gdnet_q is None:
            raise ValueError("the 'gdnet' close-view planner needs GDNet")
        anywhere = cfg.vags.close_region == "map"
        action, _, color, height, seen = fused_grasp(state.color, state.height, image.depth, image.rgb, pose,
                                                     cfg.camera, cfg.workspace, gdnet_q, anywhere, success_q, need,
                                                     cfg.grasp.half_turn)
        position, yaw = env.grasp_pose(state.replace(height=height), action[:, 1:], action[:, 0])
        close = CloseView(image=image, color=color, height=height, seen=seen, action=action)
    else:
        model = GGCNN() if ggcnn_model is None else ggcnn_model
        grasp, img = predict_grasp(model, ggcnn_params, image.depth, pose, cfg.camera, cfg.ggcnn,
                                   cfg.grasp.depth_below_surface)
        position, yaw = grasp.position, grasp.yaw
        close = CloseView(image=image, color=state.color, height=state.height,
                          seen=jnp.zeros(state.height.shape, bool), action=jnp.zeros((B, 3), jnp.int32),
                          image_grasp=img)
    return env.viewpoint_attempt(position, yaw, pose), close


def plan_attempt(cfg: Config, env: VagsEnv, state: EnvState, decision: Decision, key,
                 gdnet_q: Optional[Callable] = None, ggcnn_params=None, ggcnn_model=None,
                 success_q: Optional[Callable] = None, acting: Optional[jax.Array] = None):
    """A decision -> (the attempt of every world (``env.Attempt``), ``CloseView``): GDNet's grasp
    from the global view where ``decision.direct``, else the close-view planner's grasp at the
    viewpoint above ``decision.view`` (success_q: ``close_view_grasp``).  Every world takes the
    close view (one jitted path for all); the direct worlds' close grasps are discarded (with
    ``net.forward_needed_only`` they are not planned: the close pass runs on the moving worlds
    only, of ``acting`` (B,) bool where given).  key: the close image's sensor noise."""
    pos_d, yaw_d = env.grasp_pose(state, decision.grasp[:, 1:], decision.grasp[:, 0])
    need = None
    if cfg.net.forward_needed_only:
        need = ~decision.direct if acting is None else acting & ~decision.direct
    view_attempt, close = close_view_grasp(cfg, env, state, decision.view, key, gdnet_q, ggcnn_params, ggcnn_model,
                                           success_q, need)
    attempt = select_attempt(decision.direct, env.direct_attempt(pos_d, yaw_d), view_attempt)
    return attempt.replace(score=decision.score), close


class VagsNets:
    """The networks of VAGS's decision for one config: GDNet, VANet, the success net, GG-CNN.
    ``params`` is ``{"gdnet", "vanet", "success"}`` ({"params", "batch_stats"} each; "success"
    only for the "success" gate; "close_gdnet", GDNet of the grasps after a move, where the run
    keeps one apart), ``"ggcnn"`` ({"params"}, only for the "ggcnn" planner) and
    ``"threshold"`` (() float32, compared with the gate's score)."""

    def __init__(self, cfg: Config):
        self.cfg = cfg
        self.gdnet, self.vanet = make_qnet(cfg.net, "gdnet"), make_qnet(cfg.net, "vanet")
        self.ggcnn = GGCNN()

    def q_fn(self, net, variables) -> Callable:
        """``(color, height[, need]) -> Q`` of ``net`` (eval mode) over the worlds in groups of
        ``net.forward_batch`` (GDNet's rotations of many worlds need tens of GB at once); given
        ``need`` (B,) bool, over those worlds only (``q_in_groups``)."""
        return q_in_groups(lambda c, h: net.apply(variables, c, h, False), self.cfg.net.forward_batch)

    def gdnet_q(self, variables) -> Callable:
        """``(color, height) -> (B, R, H, W)`` GDNet's Q with ``variables`` (eval mode)."""
        return self.q_fn(self.gdnet, variables)

    def close_q(self, params: dict) -> Callable:
        """GDNet's Q for the grasps after a move: ``params["close_gdnet"]`` where the run keeps
        one apart (``rundir.GDNET_PICKS`` "split"), else ``params["gdnet"]``."""
        return self.gdnet_q(params.get("close_gdnet", params["gdnet"]))

    def close_success_q(self, params: dict) -> Optional[Callable]:
        """The success net's Q for scoring the grasps after a move where ``vags.close_score`` is
        "success", else None (GDNet's Q scores them); ValueError without a success net."""
        if self.cfg.vags.close_score != "success":
            return None
        if "success" not in params:
            raise ValueError("vags.close_score=success scores the grasps after a move with the success net, and "
                             "the run's networks have none: evaluate with --set vags.close_score=q")
        return self.q_fn(self.gdnet, params["success"])

    def q_maps(self, params: dict, color: jax.Array, height: jax.Array):
        """Global maps color (B, H, W, 3) / height (B, H, W) -> (GDNet's Q (B, R, H, W), VANet's Q
        (B, H, W), the success net's (B, R, H, W) for the "success" and "rate" gates and
        ``vags.direct_score="success"``, else None)."""
        q_grasp = self.gdnet_q(params["gdnet"])(color, height)
        q_view = self.q_fn(self.vanet, params["vanet"])(color, height)
        q_success = None
        if self.cfg.vags.gate in ("success", "rate") or self.cfg.vags.direct_score == "success":
            q_success = self.q_fn(self.gdnet, params["success"])(color, height)
        return q_grasp, q_view, q_success

    def decide(self, params: dict, state: EnvState):
        """-> (Decision, GDNet's Q (B, R, H, W), VANet's Q (B, H, W)) on the global views."""
        q_grasp, q_view, q_success = self.q_maps(params, state.color, state.height)
        decision = decide(q_grasp, q_view, params["threshold"], q_success, self.cfg.vags.gate,
                          params.get("calibration"), self.cfg.vags.view_estimate, self.cfg.vags.viewpoint,
                          params.get("gate_table"), self.cfg.vags.gate_estimate, self.cfg.vags.direct_score,
                          self.cfg.grasp.half_turn)
        return decision, q_grasp, q_view

    def plan(self, params: dict, key, env: VagsEnv, state: EnvState):
        """-> (Attempt, Decision, CloseView, GDNet's Q, VANet's Q)."""
        decision, q_grasp, q_view = self.decide(params, state)
        attempt, close = plan_attempt(self.cfg, env, state, decision, key, self.close_q(params),
                                      params.get("ggcnn"), self.ggcnn, self.close_success_q(params))
        return attempt, decision, close, q_grasp, q_view


__all__ = ["Decision", "CloseView", "greedy", "value_at", "GATE_ESTIMATES", "CLOSE_SCORES", "DIRECT_SCORES",
           "half_turn_mean", "direct_grasp", "direct_value",
           "success_estimate", "success_estimates",
           "gate_score", "update_calibration", "initial_calibration",
           "gate_threshold", "decide",
           "q_in_groups", "fused_grasp",
           "close_view_grasp", "plan_attempt", "VagsNets"]
