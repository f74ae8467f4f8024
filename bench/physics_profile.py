#!/usr/bin/env python3
"""Where does the physics time go?  Env-steps/s of the simulator under named config variants.

    python bench/physics_profile.py --worlds 4096                       # the built-in variants
    python bench/physics_profile.py --worlds 64 --variant default: --variant 'pool10:scene.copies_per_shape=1'

A variant is ``name:override;override;...`` (overrides as for ``train.py --set``; an empty list
is the default config).  For each variant, side by side in one process, after a warm-up call
that compiles, it times (median of --repeats):

  * reset  : drop + settle (``cfg.scene.settle_time``) of 10 objects in every world;
  * settle : --settle-seconds (0.2) more of physics on the settled scenes (objects resting, gripper parked),
             through ``Simulator.settle`` (parked bodies pinned, overflow checked every step);
  * raw    : the same seconds as a bare ``lax.scan`` of ``vmap(mjx.step)``, no pinning or checks
             (the difference to "settle" is our per-step bookkeeping);
  * grasp  : one grasp per world at the highest object's centre (``Simulator.grasp_at``).

and reports env-steps/s (worlds x physics steps / s) for each, plus the solver's mean
iterations, contacts and constraint rows per world on the settled scenes (impl "warp"), the
grasp success rate, physics errors and objects lost from the workspace while settling or
grasping (a variant that is fast but blows up or launches objects is no use).
"""
from __future__ import annotations

import argparse
import platform
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np
from mujoco import mjx

from timing import emit_row, parse_variant, timed
from vags_jax import config as C
from vags_jax.sim.scene import build_scene
from vags_jax.sim.simulator import Simulator

DEFAULT_VARIANTS = [
    "default:",
    "pool10:scene.copies_per_shape=1",
    "boxes10:scene.shapes=[\"cube\",\"cuboid_long\",\"cuboid_flat\",\"cuboid_tall\",\"cube_half\"]",
    "cg:sim.solver=cg",
    "iter5_ls8:sim.iterations=5;sim.ls_iterations=8",
    "tol1e-5:sim.tolerance=1e-5",
]


def profile(cfg: C.Config, n_worlds: int, n_objects: int, repeats: int, fast_raw: bool = True,
            settle_s: float = 0.2) -> dict:
    sim = Simulator(cfg, build_scene(cfg))
    B = n_worlds
    key = jax.random.PRNGKey(0)
    n = np.full(B, n_objects, np.int32)
    t0 = time.perf_counter()
    state = jax.block_until_ready(sim.reset(key, n))
    t_first = time.perf_counter() - t0
    t_reset, state = timed(lambda: sim.reset(key, n), repeats=repeats)

    n_settle = int(round(settle_s / cfg.sim.timestep))
    t_settle, settled = timed(lambda s: sim.settle(s, settle_s), state, repeats=repeats)

    step = jax.vmap(mjx.step, in_axes=(None, 0))

    def make_raw(unroll, options):
        def raw(d):
            return jax.lax.scan(lambda d, _: (step(sim.mx, d), None), d, None, length=n_settle,
                                unroll=unroll)[0]
        return jax.jit(raw, compiler_options=options)

    t_raw, _ = timed(make_raw(1, None), state.data, repeats=repeats)
    raw_fast = {}
    if cfg.sim.impl == "warp" and jax.default_backend() == "gpu" and fast_raw:
        # What MJX's own Warp benchmark (mujoco/mjx/warp/testspeed.py) does: unroll the step
        # loop and let XLA put even small graphs into CUDA graphs.
        for name, unroll, opts in (("raw_unroll4", 4, None),
                                   ("raw_unroll4_graph1", 4, {"xla_gpu_graph_min_graph_size": 1})):
            try:
                t, _ = timed(make_raw(unroll, opts), state.data, repeats=repeats)
                raw_fast[f"{name}_steps_per_s"] = B * n_settle / t
            except Exception as e:  # report and go on
                raw_fast[f"{name}_error"] = f"{type(e).__name__}: {str(e)[:200]}"

    pos = sim.object_positions(state)  # (B, P, 3)
    z = jnp.where(state.active, pos[..., 2], -jnp.inf)
    top = jnp.argmax(z, axis=1)
    target = pos[jnp.arange(B), top]
    yaw = jnp.zeros((B,), jnp.float32)
    t_grasp, (gstate, gres) = timed(lambda s: sim.grasp_at(s, target, yaw), state, repeats=repeats)

    row = {
        "variant": None, "impl": cfg.sim.impl, "worlds": B, "objects": n_objects,
        "pool": sim.P, "nv": sim.nv, "timestep": cfg.sim.timestep, "settle_seconds": settle_s,
        "reset_steps_per_s": B * sim.n_settle_reset / t_reset,
        "settle_steps_per_s": B * n_settle / t_settle,
        "raw_steps_per_s": B * n_settle / t_raw,
        "grasp_steps_per_s": B * sim.n_grasp_steps / t_grasp,
        "grasps_per_s": B / t_grasp,
        "grasp_s": t_grasp, "reset_s": t_reset,
        "grasp_success": float(np.mean(np.asarray(gres.success))),
        "errors_after_reset": int(np.asarray(state.error).sum()),
        # objects that left the workspace (launched, pushed off) while settling / grasping
        "lost_after_reset": int(B * n_objects - np.asarray(state.active).sum()),
        "lost_in_grasp": int(np.asarray(state.active).sum() - np.asarray(gstate.active).sum()
                             - np.asarray(gres.success).sum()),
        "errors_after_grasp": int(np.asarray(gstate.error).sum()),
        "overflow": int(np.asarray(gstate.overflow).sum()),
        "first_reset_s_incl_compile": t_first,
        **raw_fast,
    }
    impl = getattr(settled.data, "_impl", None)
    for name, field in (("solver_niter", "solver_niter"), ("nefc", "nefc")):
        v = getattr(impl, field, None)
        if v is not None:
            row[f"mean_{name}"] = float(np.mean(np.asarray(v)))
    if cfg.sim.impl == "warp" and impl is not None and getattr(impl, "nacon", None) is not None:
        row["mean_contacts_per_world"] = float(np.max(np.asarray(impl.nacon))) / B
    return row


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--impl", default="warp", choices=["jax", "warp"])
    p.add_argument("--worlds", type=int, nargs="+", default=[4096])
    p.add_argument("--objects", type=int, default=10)
    p.add_argument("--config", default="default")
    p.add_argument("--variant", action="append", default=None,
                   help="name:override;override (repeatable); default: a built-in list")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--set", nargs="*", default=[], help="overrides applied to every variant")
    p.add_argument("--no-fast-raw", action="store_true", help="skip the unrolled raw loops")
    p.add_argument("--settle-seconds", type=float, default=0.2,
                   help="simulated seconds of the settle and raw loops (0.2 s, 33 steps at 6 ms, is too short to "
                        "time at a few hundred worlds: give 1 or more there)")
    p.add_argument("--out", default=None, help="append the rows as JSON lines here")
    args = p.parse_args(argv)
    if not args.settle_seconds > 0:
        p.error(f"--settle-seconds must be > 0, got {args.settle_seconds}")
    variants = args.variant or DEFAULT_VARIANTS
    print(f"device: {jax.devices()[0].device_kind} ({jax.default_backend()}), jax {jax.__version__}, "
          f"{platform.node()}", flush=True)
    rows = []
    for b in args.worlds:
        for v in variants:
            name, overrides = parse_variant(v)
            try:
                cfg = C.replace(C.preset(args.config), **C.parse_overrides(args.set + overrides),
                                **{"sim.impl": args.impl})
                t = time.perf_counter()
                row = profile(cfg, b, args.objects, args.repeats, not args.no_fast_raw, args.settle_seconds)
            except Exception as e:  # report and go on with the other variants
                print(f"{name} worlds={b}: FAILED {type(e).__name__}: {str(e)[:300]}", flush=True)
                continue
            row["variant"], row["overrides"] = name, overrides
            row["wall_s"] = time.perf_counter() - t
            rows.append(row)
            emit_row(row, args.out)
    print("\n| variant | worlds | pool | nv | reset steps/s | settle steps/s | raw steps/s | grasp steps/s | grasps/s | success | errors | lost | solver iters |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['variant']} | {r['worlds']} | {r['pool']} | {r['nv']} | {r['reset_steps_per_s']:,.0f} | "
              f"{r['settle_steps_per_s']:,.0f} | {r['raw_steps_per_s']:,.0f} | {r['grasp_steps_per_s']:,.0f} | "
              f"{r['grasps_per_s']:,.0f} | {r['grasp_success']:.2f} | {r['errors_after_reset']}+{r['errors_after_grasp']} | "
              f"{r['lost_after_reset']}+{r['lost_in_grasp']} | "
              f"{r.get('mean_solver_niter', float('nan')):.1f} |")
    return 0 if rows else 1


if __name__ == "__main__":
    sys.exit(main())
