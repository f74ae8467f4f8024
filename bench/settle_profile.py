#!/usr/bin/env python3
"""How long a dropped scene takes to come to rest: what the camera sees after t seconds of settling.

    python bench/settle_profile.py --config tiny --worlds 16 --objects 3 --times 0.2 0.4 0.6 1.0 2.0
    python bench/settle_profile.py --config gpu --worlds 4096 --objects 10 \
        --times 0.4 0.5 0.6 0.7 0.8 0.9 1.0 1.5 2.0 --out bench/results/settle.jsonl      # H100

``VagsEnv`` with ``scene.settle_time = 0`` drops ``--objects`` objects into each of ``--worlds``
worlds (as every reset does: random x, y, 0.15 m up, random orientation), then simulates with
the gripper parked and stops at each of ``--times`` (seconds since the drop).  Every stop is
compared with the last one (the reference, "at rest"):

  * moved_2mm / rot_2deg: share of the objects on the table whose position differs from the
    reference by more than 2 mm (one heightmap cell) / whose orientation differs by more than
    2 degrees;
  * speed_p99 / speed_max: object speeds (m/s) at that moment, over all objects on the table;
  * cells_5mm: mean share of heightmap cells whose height differs from the reference's by more
    than 5 mm; worlds_changed: share of worlds with more than 1 % such cells (the view
    the policy would act on differs visibly);
  * lost: objects that left the workspace (or fell through the table) since the drop, per world.

One row per stop (JSON), on any device.  A settle time is long enough when the rows after it
stop changing.
"""
from __future__ import annotations

import argparse
import sys

import jax
import numpy as np

from timing import emit_row
from vags_jax import config as C
from vags_jax.env import VagsEnv


def quat_angle_deg(q1, q2):
    """Angle (deg) between unit quaternions (..., 4) wxyz."""
    dot = np.abs(np.sum(q1 * q2, axis=-1)).clip(0.0, 1.0)
    return np.degrees(2.0 * np.arccos(dot))


def profile(cfg: C.Config, n_worlds: int, n_objects: int, times: list[float], key: int,
            chunk: float = 0.1):
    """-> list of row dicts, one per time in ``times`` (sorted, seconds since the drop, each a
    multiple of ``chunk``: the physics advances ``chunk`` seconds per call, one compilation)."""
    cfg = C.replace(cfg, **{"scene.settle_time": 0.0})
    env = VagsEnv(cfg)
    sim = env.sim
    observe = jax.jit(env.observe_global)
    state = sim.reset(jax.random.PRNGKey(key), np.full(n_worlds, n_objects))
    active0 = np.asarray(state.active)
    snaps = []
    n_now = 0
    for t in times:
        while n_now < round(t / chunk):
            state = sim.settle(state, chunk)
            n_now += 1
        color, height = observe(state)
        pos, quat = (np.asarray(a) for a in sim.object_poses(state))
        vel = np.asarray(sim.object_velocities(state)[..., :3])
        t_sim = n_now * int(round(chunk / cfg.sim.timestep)) * cfg.sim.timestep
        snaps.append(dict(t=t, t_sim=t_sim, pos=pos, quat=quat, speed=np.linalg.norm(vel, axis=-1),
                          height=np.asarray(height), active=np.asarray(state.active),
                          error=np.asarray(state.error), overflow=np.asarray(state.overflow)))
    ref = snaps[-1]
    rows = []
    for s in snaps:
        on = s["active"] & ref["active"]  # on the table at both moments
        moved = np.linalg.norm(s["pos"] - ref["pos"], axis=-1) > 0.002
        turned = quat_angle_deg(s["quat"], ref["quat"]) > 2.0
        speed = s["speed"][s["active"]]
        diff = np.abs(s["height"] - ref["height"]) > 0.005
        cells = diff.reshape(n_worlds, -1).mean(axis=1)
        rows.append({
            "t": s["t"], "t_simulated": round(s["t_sim"], 6), "t_ref": ref["t"], "objects_on_table": int(on.sum()),
            "moved_2mm": float(moved[on].mean()) if on.any() else 0.0,
            "rot_2deg": float(turned[on].mean()) if on.any() else 0.0,
            "speed_p99": float(np.quantile(speed, 0.99)) if speed.size else 0.0,
            "speed_max": float(speed.max()) if speed.size else 0.0,
            "cells_5mm": float(cells.mean()),
            "worlds_changed": float((cells > 0.01).mean()),
            "lost_per_world": float((active0 & ~s["active"]).sum(axis=1).mean()),
            "errors": int(s["error"].sum()), "overflows": int(s["overflow"].sum()),
        })
    return rows


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--config", default="tiny", help="preset")
    p.add_argument("--set", nargs="*", default=[], help="config overrides section.field=value")
    p.add_argument("--worlds", type=int, default=16)
    p.add_argument("--objects", type=int, default=3)
    p.add_argument("--times", nargs="+", type=float, default=[0.2, 0.4, 0.6, 0.8, 1.0, 2.0],
                   help="seconds since the drop; the last is the reference")
    p.add_argument("--chunk", type=float, default=0.1, help="seconds of physics per call; --times are multiples of it")
    p.add_argument("--key", type=int, default=0)
    p.add_argument("--out", default=None, help="append the rows (JSON lines) here")
    args = p.parse_args(argv)
    cfg = C.replace(C.preset(args.config), **C.parse_overrides(args.set))
    if not 1 <= args.objects <= cfg.scene.max_objects:
        p.error(f"--objects must be in 1..{cfg.scene.max_objects} (scene.max_objects of this config)")
    times = sorted(set(args.times))
    if len(times) < 2 or times[0] < 0:
        p.error("--times needs at least two distinct times >= 0 (the last is the reference)")
    if args.chunk <= 0 or any(abs(t / args.chunk - round(t / args.chunk)) > 1e-6 for t in times):
        p.error(f"--times must be multiples of --chunk ({args.chunk} s)")
    print(f"device: {jax.devices()[0].device_kind} ({jax.default_backend()}), jax {jax.__version__}", flush=True)
    for row in profile(cfg, args.worlds, args.objects, times, args.key, args.chunk):
        emit_row({"config": args.config, "overrides": args.set, "worlds": args.worlds,
                  "objects": args.objects, "timestep": cfg.sim.timestep, **row}, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
