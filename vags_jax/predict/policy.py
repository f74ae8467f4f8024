"""A trained VAGS policy on single RGB-D frames (``FramePolicy``), a real camera's or the
simulator's: the run loaded once (config, networks, threshold and calibration), each frame
checked (``check_frame``) and turned into heightmaps, the decision (grasp, or move the camera)
and the close-view grasp; programs compiled on the first frame of a camera and reused.
``vags_jax.predict.commands`` is its command line (``python -m vags_jax.predict``).
"""
from __future__ import annotations

import functools
import math
import os
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Optional

import jax
import jax.numpy as jnp
import numpy as np

from vags_jax import config as C
from vags_jax.benchmark.record import _Panel
from vags_jax.config import Camera
from vags_jax.env import grasp_pose
from vags_jax.ggcnn.planner import predict_grasp
from vags_jax.perception import camera, heightmap
from vags_jax.policies import decision, rate_gate
from vags_jax.policies.catalog import GDNET_ALONE_SCORES, vags_params
from vags_jax.policies.decision import VagsNets
from vags_jax.stages import checkpoint, rundir
from vags_jax.stages.ggcnn import ggcnn_dir
from vags_jax.stages.rundir import load_gdnet

# Workspace fields a frame may move (ws.json); size and heightmap_px fix the grid the networks learned.
FIXED_WORKSPACE = ("size", "heightmap_px")
GGCNN_SCALE_TOLERANCE = 0.1  # relative focal-length difference GG-CNN's close image may have

# The key of the value a direct grasp maximized, by ``vags.direct_score``.
_DIRECT_VALUE_KEY = {"q": "q", "q_mean": "q_mean", "success": "p_success"}


@dataclass
class Frame:
    """One RGB-D frame: rgb (h, w, 3) uint8 registered to depth (h, w) metres along the optical
    axis (0 or NaN = missing); pose (4, 4) camera-to-world (OpenCV axes, metres); camera: its
    intrinsics (``Camera`` with width = w, height = h)."""
    rgb: np.ndarray
    depth: np.ndarray
    pose: np.ndarray
    camera: Camera


def _json_float(x) -> Optional[float]:
    """A float32 value as the shortest float that is the same float32 (0.175, not
    0.17500001192092896); None for inf / NaN (not JSON)."""
    x = np.float32(x)
    return float(str(x)) if np.isfinite(x) else None


def _json_floats(a) -> list:
    """An array of float32 values -> nested lists of ``_json_float``."""
    a = np.asarray(a)
    return [_json_floats(r) for r in a] if a.ndim > 1 else [_json_float(v) for v in a]


def run_config(run_dir: str, overrides: Optional[dict] = None):
    """A run's config with ``overrides`` (dotted keys; not net.*, nor the workspace's size and
    grid: the networks learned on them) -> Config.  ValueError (one line) with what to fix."""
    if not os.path.isdir(run_dir):
        raise ValueError(f"run directory {run_dir!r} does not exist" if not os.path.exists(run_dir) else
                         f"--run {run_dir!r} is a file; give the run directory train.py wrote")
    run_cfg = checkpoint.load_config(run_dir)
    overrides = dict(overrides or {})
    bad = [k for k in overrides if k.startswith("net.")]
    if bad:
        raise ValueError(f"{bad[0]}: the trained networks fix net.*; drop it")
    cfg = C.replace(run_cfg, **overrides)
    for f in FIXED_WORKSPACE:
        if getattr(cfg.workspace, f) != getattr(run_cfg.workspace, f):
            raise ValueError(f"workspace.{f} = {getattr(cfg.workspace, f)} differs from the run's "
                             f"{getattr(run_cfg.workspace, f)}: its networks learned on that grid "
                             f"({1000 * run_cfg.workspace.pixel_size:g} mm cells); move the square with "
                             f"center and table_z only")
    return cfg


def check_frame(frame: Frame, ws, what: str = "frame"):
    """``heightmap.check_frame`` on a frame for the workspace ``ws`` -> (depth, rgb, pose) as
    the programs take them; ValueError naming ``what``; ``FrameWarning`` as it warns."""
    try:
        return heightmap.check_frame(frame.depth, frame.rgb, frame.pose, frame.camera, ws)
    except (ValueError, heightmap.FrameWarning) as e:  # a FrameWarning raises where warnings are errors
        raise ValueError(f"{what}: {e}") from None


class FramePolicy:
    """A trained run's VAGS policy for single frames.

    ``FramePolicy(run_dir)`` reads the run once: its config (with ``overrides``, e.g.
    ``{"vags.local_planner": "ggcnn"}`` or a workspace moved by ``frames.read_workspace``), the
    latest stage-3 (else stage-2) networks, the gate's threshold and calibration, and GG-CNN.
    ``threshold`` overrides the gate's threshold; ``no_viewpoint`` always grasps directly with
    GDNet (the run may then hold stage 1 alone).  ``decide(frame)`` -> a JSON-ready dict (see
    ``python -m vags_jax.predict --help``); ``decide(frame, close)`` with the frame taken at the
    viewpoint it asked for -> the close-view grasp.  Raises ValueError (one line, what to fix)
    for a run without the needed networks or a bad frame; warns ``heightmap.FrameWarning`` for
    a frame unlikely to be useful.  ``params`` (the weights and the gate's threshold) are
    arguments of the compiled programs: another threshold in ``policy.params["threshold"]``
    compiles nothing.
    """
    def __init__(self, run_dir: str, overrides: Optional[dict] = None, threshold: Optional[float] = None,
                 no_viewpoint: bool = False, step: Optional[int] = None):

        if threshold is not None and no_viewpoint:
            raise ValueError("--no-viewpoint fixes the threshold at -inf: drop --threshold")
        if threshold is not None and not math.isfinite(threshold):
            raise ValueError(f"--threshold must be a finite number, got {threshold}")
        self.run_dir = run_dir
        self.cfg = cfg = run_config(run_dir, overrides)
        found = rundir.vags_stages(run_dir)
        self.gdnet_only = no_viewpoint and not found
        self.ggcnn_camera = None
        if self.gdnet_only:
            if cfg.vags.direct_score not in GDNET_ALONE_SCORES:
                raise ValueError(f"vags.direct_score={cfg.vags.direct_score} plans the direct grasps with the success "
                                 f"net, and {run_dir} has stage 1 alone: drop that setting, or train stages 2-3")
            _, variables, s = load_gdnet(run_dir, step)
            self.params = {"gdnet": variables, "threshold": np.float32(-np.inf)}
            self.source = self.gdnet_source = self.close_source = rundir.networks_source("stage1", s)
            return
        if not found:
            try:
                rundir.load_vags(run_dir, cfg, step)  # raises its one line: what to train
            except checkpoint.CheckpointError as e:
                raise ValueError(f"{e}; or pass --no-viewpoint to grasp with its GDNet alone") from None
        # The networks the config's gate and close-view planner need, from the checkpoint's
        # metadata (vags_params' own errors), before any array is read.
        d = rundir.networks_dir(run_dir, found[0])
        steps = checkpoint.checkpoint_steps(d)
        s = steps[-1] if step is None else step
        if s not in steps:
            raise ValueError(f"no checkpoint {s} in {d} (available steps: {steps}); drop --step or give one of them")
        parts = checkpoint.saved_parts(d, s)
        source = rundir.networks_source(found[0], s)

        has_ggcnn = os.path.isdir(ggcnn_dir(run_dir))
        vags_params(SimpleNamespace(success=() if "success" in parts else None, ggcnn=() if has_ggcnn else None,
                                    q_threshold=np.float32(0.0), gdnet=None, vanet=None,
                                    calibration=(np.zeros(checkpoint.part_shapes(d, s, "calibration")[0], np.float32)
                                                 if "calibration" in parts else None),
                                    gate_table=rate_gate.load(run_dir, source), source=source,
                                    gate_estimate=rate_gate.estimate_of(run_dir),
                                    gate_close_score=rate_gate.close_score_of(run_dir),
                                    gate_direct_score=rate_gate.direct_score_of(run_dir)), cfg)
        if cfg.vags.local_planner == "ggcnn":
            self.ggcnn_camera = checkpoint.load_config(ggcnn_dir(run_dir)).camera
        networks = rundir.load_vags(run_dir, cfg, s)
        self.params = vags_params(networks, cfg, -math.inf if no_viewpoint else threshold)
        self.source = networks.source
        self.gdnet_source = networks.gdnet_source  # the GDNet the run kept (its gate table's pick)
        self.close_source = networks.close_source  # the GDNet of its grasps after a move

    # ------------------------------------------------------------------ checks (numpy, nothing compiled)

    def check_close(self, close: Frame) -> None:
        """The close frame suits the close-view planner ("ggcnn": the image scale GG-CNN learned)."""
        if self.ggcnn_camera is None:
            return
        g, c = self.ggcnn_camera, close.camera
        if (c.width, c.height) != (g.width, g.height) or any(
                abs(a / b - 1) > GGCNN_SCALE_TOLERANCE for a, b in ((c.fx, g.fx), (c.fy, g.fy))):
            raise ValueError(f"close frame: GG-CNN (vags.local_planner=ggcnn) learned on {g.width} x {g.height} images "
                             f"with fx, fy = {g.fx:g}, {g.fy:g}, and this one is {c.width} x {c.height} with "
                             f"{c.fx:g}, {c.fy:g}: resize or crop it to that scale, or use --set "
                             f"vags.local_planner=gdnet, which takes any camera")

    # ------------------------------------------------------------------ deciding

    def decide(self, frame: Frame, close: Optional[Frame] = None) -> dict:
        """The decision on a global frame; with ``close`` (the frame taken at the viewpoint the
        decision asked for) the close-view grasp.  -> JSON-ready dict."""
        depth, rgb, pose = check_frame(frame, self.cfg.workspace, "global frame")
        if close is not None:
            if self.gdnet_only:
                raise ValueError("--local: with --no-viewpoint the policy never moves the camera; drop --local")
            self.check_close(close)
            c_depth, c_rgb, c_pose = check_frame(close, self.cfg.workspace, "close frame (--local)")
        g = _global_program(self.params, depth, rgb, pose, cfg=self.cfg, cam=frame.camera, gdnet_only=self.gdnet_only)
        g = {k: (v if k in ("color", "height") else np.asarray(v)) for k, v in g.items()}
        out = {"decision": "grasp" if bool(g["direct"][0]) else "move", "run": self.run_dir, "networks": self.source,
               "gdnet": self.gdnet_source, "close_gdnet": self.close_source}
        out["gate"], out["reason"] = self._gate(g)
        direct = self._heightmap_grasp(g["grasp"][0], g["position"][0], g["yaw"][0], g["direct_value"][0], "global",
                                       _DIRECT_VALUE_KEY[self.cfg.vags.direct_score])
        if out["decision"] == "grasp":
            out["grasp"] = direct
            if close is not None:
                out["note"] = "the gate chose a direct grasp from the global view; the --local frame was not used"
            return out
        view_pose = g["view_pose"][0]
        looks_at = view_pose[:3, 3] - np.array([0.0, 0.0, self.cfg.camera.viewpoint_height], np.float32)
        out["viewpoint"] = {"camera_to_world": _json_floats(view_pose), "position": _json_floats(view_pose[:3, 3]),
                            "looks_at": _json_floats(looks_at), "pixel": g["view"][0].tolist(),
                            "vanet_q": _json_float(g["p_view"][0])}
        out["direct_grasp"] = direct
        if close is None:
            return out
        out["decision"] = "grasp"
        out["close_frame"] = {"distance_to_viewpoint_m": _json_float(np.linalg.norm(c_pose[:3, 3] - view_pose[:3, 3]))}
        if self.cfg.vags.local_planner == "gdnet":
            c = _close_gdnet_program(self.params, g["color"], g["height"], c_depth, c_rgb, c_pose, cfg=self.cfg,
                                     cam=close.camera)
            c = {k: np.asarray(v) for k, v in c.items()}
            scored = "p_success" if self.cfg.vags.close_score == "success" else "q"
            out["grasp"] = self._heightmap_grasp(c["grasp"][0], c["position"][0], c["yaw"][0], c["score"][0], "close",
                                                 scored)
            out["close_frame"]["cells_seen"] = int(c["seen"])
        else:
            c = {k: np.asarray(v) for k, v in _close_ggcnn_program(self.params, c_depth, c_pose, cfg=self.cfg,
                                                                    cam=close.camera).items()}
            out["grasp"] = self._ggcnn_grasp(c)
        return out

    def _gate(self, g: dict):
        v = self.cfg.vags
        thr = float(np.asarray(self.params["threshold"]))
        score, direct = float(g["score"][0]), bool(g["direct"][0])
        verdict = "grasp directly" if direct else "move the camera to the viewpoint"
        rel = ">" if direct else "<="
        if self.gdnet_only or thr == -math.inf:
            gate = {"kind": "none", "q_max": _json_float(g["q_max"][0]), "threshold": None}
            return gate, "--no-viewpoint (threshold -inf): always grasp directly with GDNet"
        gate = {"kind": v.gate, "score": _json_float(score), "threshold": _json_float(thr), "direct": direct,
                "q_max": _json_float(g["q_max"][0])}
        if v.gate == "q":
            return gate, f"GDNet's largest Q {score:.4f} {rel} threshold {thr:.4f}: {verdict}"
        if v.gate == "rate":
            p_d = float(g["p_direct"][0])
            gate.update(p_direct=_json_float(p_d), move_value=_json_float(-score))
            return gate, (f"success estimate of the direct grasp {p_d:.3f}: a move there is worth {-score:+.4f} "
                          f"(the run's measured gate table; positive raises the picks per hour): {verdict}")
        cal = np.zeros(3) if self.params.get("calibration") is None else np.asarray(self.params["calibration"])
        p_d, p_v = float(g["p_direct"][0]), float(g["p_view"][0])
        gate.update(p_direct=_json_float(p_d), p_view=_json_float(p_v), calibration=_json_floats(cal),
                    move_cost=v.move_cost, view_estimate=v.view_estimate)
        after = (f"the run's mean success after a move {cal[2]:.3f}" if v.view_estimate == "mean" else
                 f"VANet's estimate of a grasp after a move {p_v:.3f} (bias {cal[1]:+.3f})")
        return gate, (f"success estimate of the direct grasp {p_d:.3f} (bias {cal[0]:+.3f}) against {after}: "
                      f"score {score:+.4f} {rel} threshold {thr:+.4f}: {verdict}")

    def _heightmap_grasp(self, action, position, yaw, score, view: str, scored: str = "q") -> dict:
        """scored: the key of the value the grasp maximized ("q": GDNet's Q; "q_mean": GDNet's
        half-turn mean, ``vags.direct_score`` "q_mean"; "p_success": the success net's half-turn
        mean, ``vags.close_score`` / ``vags.direct_score`` "success")."""
        return {"view": view, "planner": "gdnet", "position": _json_floats(position),
                "yaw": _json_float(yaw), "gripper_width": self.cfg.grasp.finger_stroke, scored: _json_float(score),
                "pixel": [int(action[1]), int(action[2])], "rotation": int(action[0])}

    def _ggcnn_grasp(self, c: dict) -> dict:

        ws, g = self.cfg.workspace, self.cfg.grasp
        position = c["position"][0]
        pixel = np.asarray(camera.world_xy_to_pixel(position[:2], ws))
        return {"view": "close", "planner": "ggcnn", "position": _json_floats(position),
                "yaw": _json_float(c["yaw"][0]), "gripper_width": g.finger_stroke,
                "predicted_width": _json_float(c["width"][0]), "quality": _json_float(c["quality"][0]),
                "pixel": [int(pixel[0]), int(pixel[1])],
                "rotation": int(round(float(c["yaw"][0]) / g.rotation_step)) % g.n_rotations,
                "image_pixel": [int(v) for v in c["image_pixel"][0]]}


# ----------------------------------------------------------------------------- compiled programs
# Module-level and jitted with the configs static: compiled once per (run config, camera) and
# shared by every FramePolicy of that config; params (weights, threshold) are arguments.


@functools.lru_cache(maxsize=None)
def _nets(cfg):

    return VagsNets(cfg)


@functools.partial(jax.jit, static_argnames=("cfg", "cam", "gdnet_only"))
def _global_program(params, depth, rgb, pose, *, cfg, cam, gdnet_only):
    """One global frame (depth (h, w), rgb (h, w, 3), pose (4, 4)) -> the decision's arrays
    (leading axis 1): the heightmaps, the direct grasp and the value it maximized
    (``direct_value``), the gate's figures, the grasp's pose, the viewpoint's pose."""
    nets = _nets(cfg)
    color, height = heightmap.heightmaps(depth[None], rgb[None], pose[None], cam, cfg.workspace)
    out = {"color": color, "height": height}
    if gdnet_only:  # GDNet alone: its argmax, or that of its half-turn mean (vags.direct_score)
        q_grasp = nets.gdnet_q(params["gdnet"])(color, height)
        grasp, q_max = decision.direct_grasp(q_grasp, None, cfg.vags.direct_score, cfg.grasp.half_turn)
        value = decision.direct_value(q_grasp, None, grasp, cfg.vags.direct_score, cfg.grasp.half_turn)
        out.update(grasp=grasp, q_max=q_max, score=q_max, direct=jnp.ones((1,), bool), direct_value=value)
    else:
        q_grasp, q_view, q_success = nets.q_maps(params, color, height)
        d = decision.decide(q_grasp, q_view, params["threshold"], q_success, cfg.vags.gate, params.get("calibration"),
                            cfg.vags.view_estimate, cfg.vags.viewpoint, params.get("gate_table"),
                            cfg.vags.gate_estimate, cfg.vags.direct_score, cfg.grasp.half_turn)
        _, p_view = decision.greedy(q_view)
        out.update(grasp=d.grasp, q_max=d.q_max, score=d.score, direct=d.direct, view=d.view, p_view=p_view,
                   view_pose=camera.viewpoint_pose(d.view, height, cfg.workspace, cfg.camera))
        if q_success is not None:
            out["p_direct"] = decision.success_estimate(q_success, d.grasp, cfg.vags.gate_estimate,
                                                        cfg.grasp.half_turn)
        out["direct_value"] = decision.direct_value(q_grasp, q_success, d.grasp, cfg.vags.direct_score,
                                                    cfg.grasp.half_turn)
    out["position"], out["yaw"] = grasp_pose(cfg, height, out["grasp"][:, 1:], out["grasp"][:, 0])
    return out


@functools.partial(jax.jit, static_argnames=("cfg", "cam"))
def _close_gdnet_program(params, color, height, depth, rgb, pose, *, cfg, cam):
    """The "gdnet" close-view planner on one close frame, fused into the global maps (1, H, W);
    "score" is the value its grasp maximized (``vags.close_score``)."""
    nets = _nets(cfg)
    action, score, _, fused, seen = decision.fused_grasp(color, height, depth[None], rgb[None], pose[None], cam,
                                                         cfg.workspace, nets.close_q(params),
                                                         cfg.vags.close_region == "map", nets.close_success_q(params),
                                                         half_turn=cfg.grasp.half_turn)
    position, yaw = grasp_pose(cfg, fused, action[:, 1:], action[:, 0])
    return {"grasp": action, "score": score, "position": position, "yaw": yaw, "seen": seen.sum()}


@functools.partial(jax.jit, static_argnames=("cfg", "cam"))
def _close_ggcnn_program(params, depth, pose, *, cfg, cam):
    """The "ggcnn" close-view planner: GG-CNN's best grasp in one close depth image."""
    g, img = predict_grasp(_nets(cfg).ggcnn, params["ggcnn"], depth[None], pose[None], cam, cfg.ggcnn,
                           cfg.grasp.depth_below_surface)
    return {"position": g.position, "yaw": g.yaw, "width": g.width, "quality": img.quality, "image_pixel": img.pixel}


# ----------------------------------------------------------------------------- pictures


def draw_decision(frame: Frame, result: dict, grasp_rgb=(255, 40, 40), view_rgb=(40, 220, 255)) -> np.ndarray:
    """The frame's colour image with the decision drawn on it -> (h, w, 3) uint8: a grasp as a
    line along its closing axis, as long as the gripper's opening, through the grasp point; a
    viewpoint as a cross where the camera would look down."""
    panel = _Panel(np.asarray(frame.rgb, np.uint8), frame.rgb.shape[:2])
    if "grasp" in result:
        g = result["grasp"]
        centre = np.asarray(g["position"])
        axis = np.array([math.cos(g["yaw"]), math.sin(g["yaw"]), 0.0]) * g["gripper_width"] / 2
        points = [centre - axis, centre + axis]
        colour = grasp_rgb
    else:
        points = [result["viewpoint"]["looks_at"]]
        colour = view_rgb
    uv, z = camera.project(np.asarray(points, np.float32)[None], np.asarray(frame.pose, np.float32), frame.camera)
    uv, z = np.asarray(uv)[0], np.asarray(z)[0]
    if np.all(z > 0):
        if len(points) == 2:
            panel._segment(uv[0, 1], uv[0, 0], uv[1, 1], uv[1, 0], colour)
        else:
            panel.cross(uv[0, 1], uv[0, 0], colour)
    return panel.img


__all__ = ["Frame", "FramePolicy", "run_config", "check_frame", "draw_decision"]
