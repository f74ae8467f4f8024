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
  * loop      : the steady state of a training loop (``--loop K`` iterations in one jitted scan,
                as ``vags_jax.stages.stage1`` runs them): every iteration, each world whose round is
                over starts a new scene (``VagsEnv.step_grasp_or_reset``; it settles while the
                other worlds grasp), every other world grasps with the scripted heuristic
                (highest object, narrowest closing axis), then every world is rendered once.
                Reported: grasp attempts/s (resets, renders and heightmaps included), the
                share of world-iterations spent resetting and the heuristic's success rate.
The attempt / grasp rows grasp at the highest heightmap cell with rotation 0: the physics cost
does not depend on where it grasps.  Timings are the median of --repeats calls (the loop: one
call of K iterations after the call that compiled it); everything stays
on the device.
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

from timing import parse_variant, timed
from vags_jax import config as C
from vags_jax.env import VagsEnv
from vags_jax.policies.catalog import min_width_grasp


# Long (one reason): one benchmark's setup, warm-up and timed loops in order.
def bench_one(cfg, n_worlds, n_objects, repeats, loop_iterations=0, only_loop=False):
    env = VagsEnv(cfg)
    env.prepare(n_worlds)
    n = jnp.full((n_worlds,), n_objects, jnp.int32)

    def highest(state):
        flat = state.height.reshape(n_worlds, -1).argmax(axis=1)
        H = cfg.workspace.heightmap_px
        return jnp.stack([flat // H, flat % H], axis=1), jnp.zeros((n_worlds,), jnp.int32)

    @jax.jit
    def observe(state):
        return env.observe_global(state.sim, jax.random.PRNGKey(0))  # key: the sensor model's noise

    @jax.jit
    def attempt(key, n):
        s = env.step_reset(key, n)
        pix, rot = highest(s)
        s, r = env.step_grasp(s, pix, rot, jax.random.fold_in(key, 1))
        return s.height, r.success

    @jax.jit
    def grasp(state):
        pix, rot = highest(state)
        s, r = env.step_grasp(state, pix, rot, jax.random.PRNGKey(1))
        return s.height, r.success

    def loop(state, key):
        """loop_iterations training-loop steps -> (state, attempts, successes, resets, lost,
        errors): lost = objects that left the workspace during a grasp without being grasped;
        errors = grasping worlds whose physics failed (a world's flag clears when it restarts,
        so they are counted as they happen, not at the end)."""
        def body(carry, k):
            s, att, suc, res, lost, err = carry
            pending = env.round_over(s) | s.sim.error  # rounds that ended last iteration
            action = min_width_grasp(s.height, cfg)[0]  # (B, 3) [rotation, row, col]
            before = s.sim.active.sum(axis=1)
            k_reset, k_obs = jax.random.split(k)  # k_obs: the sensor model's noise
            s, r = env.step_grasp_or_reset(s, action[:, 1:], action[:, 0], pending, k_reset, n, k_obs)
            grasped = ~pending
            gone = before - s.sim.active.sum(axis=1) - r.success.astype(jnp.int32)
            return (s, att + grasped.sum(), suc + (r.success & grasped).sum(), res + pending.sum(),
                    lost + jnp.where(grasped, gone, 0).sum(), err + (s.sim.error & grasped).sum()), None

        zero = jnp.zeros((), jnp.int32)
        (s, *counts), _ = jax.lax.scan(body, (state,) + (zero,) * 5, jax.random.split(key, loop_iterations))
        return (s, *counts)

    key = jax.random.PRNGKey(0)
    t0 = time.perf_counter()
    state = env.reset(key, np.full(n_worlds, n_objects))
    t_first_reset = time.perf_counter() - t0
    row = {
        "impl": cfg.sim.impl, "renderer": cfg.camera.renderer, "worlds": n_worlds,
        "objects": n_objects, "image": f"{cfg.camera.width}x{cfg.camera.height}",
        "heightmap": cfg.workspace.heightmap_px,
        "physics_steps_per_grasp": env.sim.n_grasp_steps,
        "physics_steps_per_reset": env.sim.n_settle_reset,
        "first_reset_s_incl_compile": t_first_reset,
    }
    if not only_loop:
        t_obs, _ = timed(observe, state, repeats=repeats)
        t_att, (_, succ) = timed(attempt, key, n, repeats=repeats)
        t_grasp, _ = timed(grasp, state, repeats=repeats)
        steps_per_attempt = env.sim.n_settle_reset + env.sim.n_grasp_steps
        row.update({
            "heightmaps_per_s": n_worlds / t_obs,
            "attempts_per_s": n_worlds / t_att,
            "grasps_per_s": n_worlds / t_grasp,
            "physics_steps_per_attempt": steps_per_attempt,
            "env_steps_per_s_in_attempt": n_worlds * steps_per_attempt / t_att,
            "scripted_success": float(np.mean(np.asarray(succ))),
        })
    if loop_iterations:
        loop_jit = jax.jit(loop)
        t0 = time.perf_counter()
        state2 = jax.block_until_ready(loop_jit(state, key)[0])  # compile + run (warm-up)
        row["loop_first_call_s"] = time.perf_counter() - t0
        # Timed: the next loop_iterations iterations (the first call compiled and warmed up).
        t0 = time.perf_counter()
        s_end, att, suc, res, lost, err = jax.block_until_ready(loop_jit(state2, jax.random.PRNGKey(1)))
        t_loop = time.perf_counter() - t0
        att, suc, res, lost = int(att), int(suc), int(res), int(lost)
        row.update({
            "loop_iterations": loop_iterations,
            "loop_attempts_per_s": att / t_loop,
            "loop_attempts": att,
            "loop_success": suc / max(att, 1),
            "loop_reset_share": res / (res + att),
            "loop_lost_per_attempt": lost / max(att, 1),
            "loop_errors": int(err),
            "loop_overflow": int(np.asarray(s_end.sim.overflow).sum()),
            "loop_s": t_loop,
        })
    return row


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--impl", nargs="+", default=["jax"], choices=["jax", "warp"])
    p.add_argument("--renderer", default="jax", choices=["jax", "warp"])
    p.add_argument("--worlds", nargs="+", type=int, default=[4])
    p.add_argument("--objects", type=int, default=10)
    p.add_argument("--config", default="default", help="preset (image size, heightmap size, scene)")
    p.add_argument("--set", nargs="*", default=[], help="config overrides section.field=value")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--loop", type=int, default=0, metavar="K",
                   help="also time K iterations of the steady-state training loop (0: skip)")
    p.add_argument("--only-loop", action="store_true", help="time the loop only")
    p.add_argument("--variant", action="append", default=[], metavar="NAME:A=1;B=2",
                   help="run these named override sets (on top of --set) one after the other "
                        "in this process; repeat the flag; default: one run with --set only")
    p.add_argument("--out", default=None, help="write the rows as JSON here")
    args = p.parse_args(argv)

    rows = []
    print(f"device: {jax.devices()[0].device_kind} ({jax.default_backend()}), "
          f"jax {jax.__version__}, {platform.node()}", flush=True)
    variants = [parse_variant(v) for v in args.variant] or [("", [])]
    for impl in args.impl:
        for b in args.worlds:
            for name, ov in variants:
                cfg = C.replace(C.preset(args.config), **C.parse_overrides(args.set + ov),
                                **{"sim.impl": impl, "camera.renderer": args.renderer})
                try:
                    row = bench_one(cfg, b, args.objects, args.repeats, args.loop, args.only_loop)
                except Exception as e:  # report and continue with the other settings
                    print(f"impl={impl} worlds={b} variant={name!r}: FAILED {type(e).__name__}: "
                          f"{str(e)[:400]}", flush=True)
                    continue
                row = {"variant": name, "overrides": args.set + ov, **row}
                rows.append(row)
                print(json.dumps(row), flush=True)
                if args.out:  # after every row, so a run cut short keeps what it measured
                    write_rows(args.out, rows)
    print("\n| variant | impl | renderer | worlds | objects | image | heightmaps/s | grasp attempts/s (reset+render+hm+grasp) | grasps/s (no reset) | env-steps/s | loop: grasp attempts/s | loop: resetting | loop: success | loop: lost / attempt |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        g = lambda k, f="{:,.0f}": f.format(r[k]) if k in r else "-"  # noqa: E731
        print(f"| {r['variant'] or '-'} | {r['impl']} | {r['renderer']} | {r['worlds']} | {r['objects']} | {r['image']} | "
              f"{g('heightmaps_per_s')} | {g('attempts_per_s')} | {g('grasps_per_s')} | "
              f"{g('env_steps_per_s_in_attempt')} | {g('loop_attempts_per_s')} | "
              f"{g('loop_reset_share', '{:.1%}')} | {g('loop_success', '{:.1%}')} | "
              f"{g('loop_lost_per_attempt', '{:.3f}')} |")
    return 0 if rows else 1


def write_rows(path: str, rows: list[dict]) -> None:
    """Write the rows measured so far, with the device and the command line, as one JSON file."""
    with open(path, "w") as f:
        json.dump({"device": str(jax.devices()[0].device_kind), "argv": sys.argv[1:], "rows": rows}, f, indent=1)


if __name__ == "__main__":
    sys.exit(main())
