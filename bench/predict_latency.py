#!/usr/bin/env python3
"""How long a trained policy takes to decide on one 640 x 480 RGB-D frame (``vags_jax.predict``).

    python bench/predict_latency.py --run runs/vags                    # a trained run (GPU)
    python bench/predict_latency.py --config tiny --repeats 5          # CPU check: random networks

The frame: the run's scene with ``--objects`` blocks placed on the table by hand (no physics
to settle), rendered by the simulator's camera from the global pose at 640 x 480 (fx = fy =
618.62, the default camera; ``--width`` / ``--height`` scale it), sensor noise included.  The
policy is ``FramePolicy(run)``: the first ``decide`` compiles its programs (reported apart);
then ``--repeats`` decisions on the same frame are timed one by one, each the whole call a
robot makes: the frame's checks (numpy), the heightmaps, GDNet / VANet / the success net, the
gate and the grasp or viewpoint, back on the host as a JSON-ready dict.  ``--close`` also
times the decision with the close frame taken at the viewpoint (the close-view planner on top).

The frame is drawn by the run's renderer, or by the JAX ray caster where the run's is Warp and
this machine has no NVIDIA GPU (a `gpu` run timed on a CPU; the report's ``frame_renderer``):
the policy renders nothing, so its timing does not depend on it.

``--config`` makes a run with random networks in a temporary directory: the latency does not
depend on the weights.  Prints one JSON object (median, p90, min, max in ms; the device);
``--out`` writes it too.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def random_run(cfg, directory: str) -> str:
    """A run directory with stage 3's networks drawn at random (GDNet, VANet, success net), and
    under the "rate" gate a gate table of one bin that moves (its values do not change the time
    a decision takes; a trained run's comes from ``stages.gate_measure``)."""
    import jax
    import numpy as np

    from vags_jax.nets import init_qnet, make_qnet
    from vags_jax.policies import rate_gate
    from vags_jax.stages import checkpoint, rundir

    H = cfg.workspace.heightmap_px
    gd = init_qnet(jax.random.PRNGKey(0), make_qnet(cfg.net, "gdnet"), H, H)
    va = init_qnet(jax.random.PRNGKey(1), make_qnet(cfg.net, "vanet"), H, H)
    checkpoint.save_config(directory, cfg)
    checkpoint.save(rundir.networks_dir(directory, "stage3"), 1, {
        "gdnet": gd, "vanet": va, "success": gd, "threshold": np.float32(0.0),
        "calibration": np.zeros(3, np.float32)})
    if cfg.vags.gate == "rate":
        source = rundir.networks_source("stage3", 1)
        one_bin = rate_gate.GateTable(edges=(), states=(1,), direct=(0.5,), moved=(0.6,), extra_seconds=(0.5,),
                                      rate=0.1, move_value=(0.05,))
        rate_gate.save(directory, one_bin, {"networks": source, "gdnet": source, "close_gdnet": source,
                                            "estimate": cfg.vags.gate_estimate, "close_score": cfg.vags.close_score,
                                            "direct_score": cfg.vags.direct_score})
    return directory


def frame_renderer(cfg) -> str:
    """The renderer that draws the input frame: the run's, except the Warp renderer off a GPU, where
    the JAX ray caster draws it (the policy itself renders nothing, so its timing is the same)."""
    import jax

    return "jax" if cfg.camera.renderer == "warp" and jax.default_backend() != "gpu" else cfg.camera.renderer


def bench_frame(cfg, width: int, height: int, objects: int, seed: int):
    """(global Frame, a function pose -> close Frame) of a hand-placed scene, rendered at
    ``width`` x ``height`` with the default camera's focal length scaled to the width."""
    import jax
    import numpy as np

    from vags_jax import config as C
    from vags_jax.env import VagsEnv
    from vags_jax.perception import camera
    from vags_jax.predict import Frame, frames

    f = 618.62 * width / 640
    cam = C.replace(cfg, **{"camera.width": width, "camera.height": height, "camera.fx": f, "camera.fy": f,
                            "camera.cx": None, "camera.cy": None, "camera.renderer": frame_renderer(cfg)})
    env = VagsEnv(cam)
    n = min(objects, cam.scene.max_objects)
    rng = np.random.default_rng(seed)
    P = len(env.scene.shape_names)
    pos = np.zeros((1, P, 3), np.float32)
    active = np.zeros((1, P), bool)
    half = cam.workspace.size / 2 - 0.06
    pos[0, :n, :2] = rng.uniform(-half, half, (n, 2)) + np.asarray(cam.workspace.center)
    pos[0, :n, 2] = 0.05
    active[0, :n] = True
    quat = np.tile(np.array([1.0, 0, 0, 0], np.float32), (1, P, 1))
    sim = env.sim.set_objects(env.sim.empty(1), pos, quat, active)
    intr = C.Camera(**frames.intrinsics_dict(cam.camera))

    def frame_at(pose, k):
        rgb, depth, p = frames.render_frame(env, sim, pose, jax.random.PRNGKey(seed + k))
        return Frame(rgb=rgb, depth=depth, pose=p, camera=intr)

    return frame_at(np.asarray(camera.global_pose(cam.camera)), 0), frame_at


def timed(fn, repeats: int) -> dict:
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(1000 * (time.perf_counter() - t))
    times.sort()
    return {"median_ms": round(statistics.median(times), 2), "p90_ms": round(times[int(0.9 * (len(times) - 1))], 2),
            "min_ms": round(times[0], 2), "max_ms": round(times[-1], 2), "repeats": repeats}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--run", default=None, help="a trained run (stage 2 or 3 networks)")
    p.add_argument("--config", default=None, help="without --run: a preset, with random networks (tiny on CPU)")
    p.add_argument("--repeats", type=int, default=20)
    p.add_argument("--width", type=int, default=640)
    p.add_argument("--height", type=int, default=480)
    p.add_argument("--objects", type=int, default=3, help="blocks on the table (at most scene.max_objects)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--close", action="store_true", help="also time the decision with the close frame")
    p.add_argument("--set", nargs="*", default=[], metavar="SECTION.FIELD=VALUE",
                   help="overrides for the policy, as predict's --set (e.g. vags.local_planner=ggcnn)")
    p.add_argument("--out", default=None, help="write the JSON here too")
    args = p.parse_args(argv)
    if (args.run is None) == (args.config is None):
        p.error("give --run RUN or --config PRESET")
    if args.repeats < 1:
        p.error("--repeats must be >= 1")
    from vags_jax import config as C

    try:
        overrides = C.parse_overrides(args.set)
    except ValueError as e:
        p.error(f"--set: {e}")

    import jax
    import numpy as np

    from vags_jax.predict import FramePolicy, check_frame
    from vags_jax.stages import checkpoint

    run = args.run or random_run(C.preset(args.config), tempfile.mkdtemp(prefix="predict_latency_"))
    cfg = checkpoint.load_config(run)
    frame, frame_at = bench_frame(cfg, args.width, args.height, args.objects, args.seed)
    t = time.perf_counter()
    policy = FramePolicy(run, overrides)
    load_s = time.perf_counter() - t
    t = time.perf_counter()
    first = policy.decide(frame)
    first_ms = 1000 * (time.perf_counter() - t)
    report = {"run": run, "networks": policy.source, "device": str(jax.devices()[0]), "frame": [args.width, args.height],
              "trunk": policy.cfg.net.trunk, "dtype": policy.cfg.net.dtype, "heightmap_px": cfg.workspace.heightmap_px,
              "gate": policy.cfg.vags.gate, "overrides": args.set, "frame_renderer": frame_renderer(cfg),
              "load_s": round(load_s, 2), "first_decision_ms": round(first_ms, 1),
              "decision": timed(lambda: policy.decide(frame), args.repeats),
              "checks_only": timed(lambda: check_frame(frame, policy.cfg.workspace), args.repeats)}
    if args.close:
        # Force a move so the close-view planner runs: the gate's threshold at +inf.
        policy.params = {**policy.params, "threshold": np.float32(np.inf)}
        view = np.asarray(policy.decide(frame)["viewpoint"]["camera_to_world"], np.float32)
        close = frame_at(view, 1)
        t = time.perf_counter()
        policy.decide(frame, close)
        report["first_close_decision_ms"] = round(1000 * (time.perf_counter() - t), 1)
        report["decision_with_close_frame"] = timed(lambda: policy.decide(frame, close), args.repeats)
    report["first_result"] = first["decision"]
    text = json.dumps(report, indent=1)
    print(text)
    if args.out:
        os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
        with open(args.out, "w") as f:
            f.write(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
