"""A trained VAGS policy on RGB-D frames: a real camera's, or frames written from the simulator.

    python -m vags_jax.predict --run RUN --rgb rgb.png --depth depth.png --intrinsics K.json --pose pose.json
    python -m vags_jax.predict --run RUN ... --local close_rgb.png close_depth.png close_pose.json
    python -m vags_jax.predict write-frames --run RUN --out frames [--seed 0] [--objects 3] [--at decision.json]
    python -m vags_jax.predict execute --run RUN --seed 0 --objects 3 --grasp decision.json

The first form prints ONE JSON object: ``"decision": "grasp"`` with the grasp in the world
frame, or ``"decision": "move"`` with the camera pose to move to, and ``"gate"`` / ``"reason"``:
the gate's figures against its threshold (docs/method.md, "Decision"); ``"networks"`` and
``"gdnet"`` name the checkpoints played (GDNet's is stage 2's where the run's gate table kept
it: ``vags.stage3_gdnet_pick``), ``"close_gdnet"`` that of the grasp after a move.  Take the frame at that
pose and run it again with ``--local``: the close-view grasp (``vags.local_planner`` "gdnet":
the close view fused into the global heightmaps, GDNet's argmax where it looked; "ggcnn":
GG-CNN on the close depth image).  ``--out-image`` draws the decision on the frame.

``write-frames`` writes the simulator's frames of a scene (the scene of ``--seed`` with
``--objects`` objects, dropped and settled as in training) in these formats, from the global
pose or from ``--at`` (a pose file, or predict's JSON output: its viewpoint); ``execute``
grasps in that scene as a predict output says and prints the outcome.  So the whole path runs
without a robot.  README "On a real robot" states the formats and conventions
(``vags_jax.predict.frames`` reads and writes them).

``FramePolicy`` is the same in Python: it loads a run once (config, networks, threshold and
calibration) and decides on single frames; its programs are compiled on the first frame of a
camera and reused.  Every bad input ends the command with one line ``predict: error: ...``
naming what to fix (exit code 2), before anything is compiled.
"""
from __future__ import annotations

import argparse
import os
import sys
import warnings

import jax.numpy as jnp
import numpy as np

from vags_jax import cli
from vags_jax import config as C
from vags_jax.benchmark.images import save_png
from vags_jax.env import VagsEnv
from vags_jax.perception import camera, heightmap, render
from vags_jax.predict import frames
from vags_jax.predict.policy import (
    Frame,
    FramePolicy,
    check_frame,
    draw_decision,
    run_config,
)
from vags_jax.stages import checkpoint

PROG = "predict"
CLOSE_TOLERANCE = 0.05  # m: a close frame further than this from the suggested viewpoint is reported


def _parser():
    p = cli.ArgumentParser(prog=PROG, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--run", required=True, help="run directory written by train.py (stage 2 or 3 networks)")
    p.add_argument("--rgb", required=True, help="colour image: 8-bit RGB .png, or (h, w, 3) uint8 .npy")
    p.add_argument("--depth", required=True, help="depth image: 16-bit .png in millimetres, or (h, w) float .npy in metres")
    p.add_argument("--intrinsics", required=True, metavar="K.json", help='{"fx", "fy", "cx", "cy", "width", "height"}')
    p.add_argument("--pose", required=True, metavar="POSE.json", help="4 x 4 camera-to-world transform (metres)")
    p.add_argument("--workspace", default=None, metavar="WS.json",
                   help='moves the workspace square: {"center": [x, y], "table_z": z} (default: the run\'s)')
    p.add_argument("--local", nargs=3, default=None, metavar=("RGB", "DEPTH", "POSE.json"),
                   help="the frame taken at the viewpoint a previous call asked for: the close-view grasp")
    p.add_argument("--out-image", default=None, metavar="PATH.png", help="the decision drawn on the frame")
    p.add_argument("--threshold", type=float, default=None, help="the gate's threshold (default: the run's)")
    p.add_argument("--no-viewpoint", action="store_true", help="always grasp directly with GDNet (threshold -inf)")
    p.add_argument("--step", type=cli.int_in(0), default=None, help="networks checkpoint step (default: latest)")
    p.add_argument("--set", nargs="*", default=[], metavar="SECTION.FIELD=VALUE",
                   help="config overrides, e.g. vags.local_planner=ggcnn vags.move_cost=0.1 (not net.* or workspace.*)")
    cli.add_cache_dir(p)
    return p


def read_frame(rgb: str, depth: str, intrinsics: str, pose: str) -> Frame:
    """A frame's four files -> Frame; ValueError (one line) naming the file and the fix."""
    cam = frames.read_intrinsics(intrinsics)
    d = frames.read_depth(depth)
    c = frames.read_rgb(rgb)
    p = frames.read_pose(pose)
    frames.check_size(c, d, cam, rgb, depth, intrinsics)
    return Frame(rgb=c, depth=d, pose=p, camera=cam)


def main_predict(argv) -> int:
    args = _parser().parse_args(argv)
    error = cli.use_compile_cache(PROG, args.cache_dir)
    if error is not None:
        return error

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", heightmap.FrameWarning)
            frame = read_frame(args.rgb, args.depth, args.intrinsics, args.pose)
            close = None
            if args.local:
                close = read_frame(args.local[0], args.local[1], args.intrinsics, args.local[2])
            if args.out_image:
                cli.check_writable_file(args.out_image, "--out-image")
            overrides = C.parse_overrides(args.set)
            ws_keys = [k for k in overrides if k.startswith("workspace.")]
            if ws_keys:
                raise ValueError(f"{ws_keys[0]}: give the workspace with --workspace WS.json")
            if args.workspace:
                overrides.update(frames.read_workspace(args.workspace))
            # The frames first (they need the run's config alone), then the networks.
            ws = run_config(args.run, overrides).workspace
            check_frame(frame, ws, "global frame")
            if close is not None:
                check_frame(close, ws, "close frame (--local)")
            policy = FramePolicy(args.run, overrides, args.threshold, args.no_viewpoint, args.step)
            result = policy.decide(frame, close)
    except (ValueError, heightmap.FrameWarning) as e:  # includes CheckpointError and config validation
        return cli.fail(PROG, e)
    if result.get("close_frame", {}).get("distance_to_viewpoint_m", 0.0) > CLOSE_TOLERANCE:
        print(f"{PROG}: warning: the close frame was taken {100 * result['close_frame']['distance_to_viewpoint_m']:.1f} "
              f"cm from the viewpoint asked for", file=sys.stderr)
    if args.out_image:

        shown = close if close is not None and result["grasp"]["view"] == "close" else frame
        save_png(args.out_image, draw_decision(shown, result))
    print(frames.json_text(result))
    return 0


def _sim_parser(command: str):
    p = cli.ArgumentParser(prog=f"{PROG} {command}", description=__doc__,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--run", default=None, help="run directory (its config: scene, camera, workspace)")
    p.add_argument("--config", default=None, help="preset without --run: tiny | gpu | gpu-edge | paper | default")
    p.add_argument("--set", nargs="*", default=[], metavar="SECTION.FIELD=VALUE", help="config overrides")
    p.add_argument("--seed", type=cli.int_in(0, 2**32 - 1), default=0, help="the scene (default 0)")
    p.add_argument("--objects", type=cli.int_in(1), default=None,
                   help="objects in the scene (default: scene.max_objects)")
    if command == "write-frames":
        p.add_argument("--out", required=True, help="directory for rgb.png, depth.png, pose.json, K.json, ws.json")
        p.add_argument("--at", default=None, metavar="POSE.json",
                       help="render at this pose (a pose file, or predict's output: its viewpoint) instead of the "
                            "global pose")
        p.add_argument("--prefix", default=None, help="file name prefix (default: none, or 'close_' with --at)")
        p.add_argument("--depth-format", choices=("png", "npy"), default="png",
                       help="png: 16-bit millimetres, as a sensor gives (default); npy: float32 metres")
    else:
        p.add_argument("--grasp", required=True, metavar="DECISION.json", help="predict's output with a grasp")
    cli.add_cache_dir(p)
    return p


def _sim_config(args):

    if args.run and args.config:
        raise ValueError("--run uses the run's own config.json; drop --config")
    if args.run and not os.path.isdir(args.run):
        raise ValueError(f"run directory {args.run!r} does not exist")
    base = checkpoint.load_config(args.run) if args.run else C.preset("tiny" if args.config is None else args.config)
    cfg = C.replace(base, **C.parse_overrides(args.set))
    n = cfg.scene.max_objects if args.objects is None else args.objects
    if n > cfg.scene.max_objects:
        raise ValueError(f"--objects {n} exceeds scene.max_objects = {cfg.scene.max_objects}")
    render.check_renderer(cfg.camera)  # a gpu run's Warp renderer on a machine without one
    return cfg, n


def _read_grasp(path: str):

    obj = frames._json(path, "--grasp")
    g = obj.get("grasp") if isinstance(obj, dict) else None
    if not isinstance(g, dict) or "position" not in g or "yaw" not in g:
        what = f"decision {obj.get('decision')!r} without a grasp" if isinstance(obj, dict) else "not a predict output"
        raise ValueError(f"--grasp {path}: {what}; run predict (with --local after a move) and give its output")
    position = np.array([frames._number(path, "grasp.position", v) for v in g["position"]], np.float32)
    if position.shape != (3,):
        raise ValueError(f"--grasp {path}: grasp.position must be [x, y, z]")
    return position, np.float32(frames._number(path, "grasp.yaw", g["yaw"]))


def main_sim(command: str, argv) -> int:
    args = _sim_parser(command).parse_args(argv)
    error = cli.use_compile_cache(f"{PROG} {command}", args.cache_dir)
    if error is not None:
        return error

    try:
        cfg, n = _sim_config(args)
        pose = grasp = None
        if command == "write-frames":
            cli.check_parent_writable(os.path.join(args.out, "x"), "--out")
            if os.path.exists(args.out) and not os.path.isdir(args.out):
                raise ValueError(f"--out {args.out!r} is a file; give a directory")
            if args.at:
                pose = frames.pose_from_file(args.at)
        else:
            grasp = _read_grasp(args.grasp)
    except ValueError as e:
        return cli.fail(f"{PROG} {command}", e)


    env = VagsEnv(cfg)
    state = frames.scene_state(env, args.seed, n)
    if command == "execute":
        # The grasp, then the simulator's next view (its sensor noise needs a key).
        _, result = env.grasp_at(state, jnp.asarray(grasp[0])[None], jnp.asarray(grasp[1])[None],
                                 frames.simulator_frame_key(args.seed, 2))
        print(frames.json_text({"success": bool(result.success[0]), "object": int(result.object[0]),
                                "objects_before": n, "seed": args.seed}))
        return 0
    at = pose if pose is not None else np.asarray(camera.global_pose(cfg.camera))
    rgb, depth, _ = frames.render_frame(env, state.sim, at, frames.simulator_frame_key(args.seed, int(pose is not None)))
    prefix = args.prefix if args.prefix is not None else ("close_" if pose is not None else "")
    paths = frames.write_frame(args.out, rgb, depth, at, cfg.camera, cfg.workspace, prefix, args.depth_format)
    print(frames.json_text(paths))
    return 0


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv and argv[0] in ("write-frames", "execute"):
        return main_sim(argv[0], argv[1:])
    return main_predict(argv)


__all__ = ["read_frame", "main"]
