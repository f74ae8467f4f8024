#!/usr/bin/env python3
"""Environment throughput: heightmaps/s and grasp attempts/s, per physics impl and batch size.

    python bench/env_throughput.py                                   # CPU, impl jax, small batch
    python bench/env_throughput.py --impl jax warp --worlds 1024 4096 --out bench/env.json   # GPU

For each (impl, worlds) it times, after a warm-up call that compiles:
  * observe   : global render (ray caster or Warp renderer) + colour/height heightmaps;
  * attempt   : one full grasp attempt = reset (drop + settle N objects) + global render +
                heightmaps + grasp (physics of approach/descend/close/lift) + re-render +
                heightmaps of the result -- the figure the foundation issue asks for;
  * grasp     : grasp + re-render + heightmaps only (a training step between resets).
The grasp is scripted (highest heightmap cell, rotation 0): the physics cost does not depend on
where it grasps.  Timings are the median of --repeats calls; everything stays on the device.
"""
from __future__ import annotations

import argparse
import json
import platform
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np

from vags_jax import config as C
from vags_jax.env import VagsEnv


def timed(fn, *args, repeats=3):
    out = jax.block_until_ready(fn(*args))  # compile + warm up
    ts = []
    for _ in range(repeats):
        t = time.perf_counter()
        out = jax.block_until_ready(fn(*args))
        ts.append(time.perf_counter() - t)
    return float(np.median(ts)), out


def bench_one(cfg, n_worlds, n_objects, repeats):
    env = VagsEnv(cfg)
    env.prepare(n_worlds)
    n = jnp.full((n_worlds,), n_objects, jnp.int32)

    def highest(state):
        flat = state.height.reshape(n_worlds, -1).argmax(axis=1)
        H = cfg.workspace.heightmap_px
        return jnp.stack([flat // H, flat % H], axis=1), jnp.zeros((n_worlds,), jnp.int32)

    @jax.jit
    def observe(state):
        return env.observe_global(state.sim)

    @jax.jit
    def attempt(key, n):
        s = env.step_reset(key, n)
        pix, rot = highest(s)
        s, r = env.step_grasp(s, pix, rot)
        return s.height, r.success

    @jax.jit
    def grasp(state):
        pix, rot = highest(state)
        s, r = env.step_grasp(state, pix, rot)
        return s.height, r.success

    key = jax.random.PRNGKey(0)
    t0 = time.perf_counter()
    state = env.reset(key, np.full(n_worlds, n_objects))
    t_first_reset = time.perf_counter() - t0
    t_obs, _ = timed(observe, state, repeats=repeats)
    t_att, (_, succ) = timed(attempt, key, n, repeats=repeats)
    t_grasp, _ = timed(grasp, state, repeats=repeats)
    steps_per_attempt = env.sim.n_settle_reset + env.sim.n_grasp_steps
    return {
        "impl": cfg.sim.impl, "renderer": cfg.camera.renderer, "worlds": n_worlds,
        "objects": n_objects, "image": f"{cfg.camera.width}x{cfg.camera.height}",
        "heightmap": cfg.workspace.heightmap_px,
        "heightmaps_per_s": n_worlds / t_obs,
        "attempts_per_s": n_worlds / t_att,
        "grasps_per_s": n_worlds / t_grasp,
        "physics_steps_per_attempt": steps_per_attempt,
        "env_steps_per_s_in_attempt": n_worlds * steps_per_attempt / t_att,
        "scripted_success": float(np.mean(np.asarray(succ))),
        "first_reset_s_incl_compile": t_first_reset,
    }


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--impl", nargs="+", default=["jax"], choices=["jax", "warp"])
    p.add_argument("--renderer", default="jax", choices=["jax", "warp"])
    p.add_argument("--worlds", nargs="+", type=int, default=[4])
    p.add_argument("--objects", type=int, default=10)
    p.add_argument("--config", default="default", help="preset (image size, heightmap size, scene)")
    p.add_argument("--set", nargs="*", default=[], help="config overrides section.field=value")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--out", default=None, help="write the rows as JSON here")
    args = p.parse_args(argv)

    rows = []
    print(f"device: {jax.devices()[0].device_kind} ({jax.default_backend()}), "
          f"jax {jax.__version__}, {platform.node()}", flush=True)
    for impl in args.impl:
        for b in args.worlds:
            cfg = C.replace(C.preset(args.config), **C.parse_overrides(args.set),
                            **{"sim.impl": impl, "camera.renderer": args.renderer})
            try:
                row = bench_one(cfg, b, args.objects, args.repeats)
            except Exception as e:  # report and continue with the other settings
                print(f"impl={impl} worlds={b}: FAILED {type(e).__name__}: {str(e)[:400]}", flush=True)
                continue
            rows.append(row)
            print(json.dumps(row), flush=True)
    print("\n| impl | renderer | worlds | objects | image | heightmaps/s | grasp attempts/s (reset+render+hm+grasp) | grasps/s (no reset) | env-steps/s |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['impl']} | {r['renderer']} | {r['worlds']} | {r['objects']} | {r['image']} | "
              f"{r['heightmaps_per_s']:,.0f} | {r['attempts_per_s']:,.0f} | {r['grasps_per_s']:,.0f} | "
              f"{r['env_steps_per_s_in_attempt']:,.0f} |")
    if args.out:
        with open(args.out, "w") as f:
            json.dump({"device": str(jax.devices()[0].device_kind), "rows": rows}, f, indent=1)
    return 0 if rows else 1


if __name__ == "__main__":
    sys.exit(main())
