#!/usr/bin/env python3
"""Where one MuJoCo Warp physics step of our world spends its time (GPU, impl "warp").

    python bench/step_breakdown.py --worlds 4096                 # settled 10-object scenes
    python bench/step_breakdown.py --worlds 4096 --variant default: --variant 'tol6:sim.tolerance=1e-6'

Scenes are made once by our own ``Simulator.reset`` (MJX impl "warp", under JAX, with the
``--set`` config), then, for each ``--variant`` (``name:override;override``, as for
``physics_profile.py``; only settings that keep the model's coordinates, e.g. ``sim.*``), the
settled qpos / qvel are copied into MuJoCo Warp's own ``Data`` and stepped there without JAX, with the
gripper parked (all 10 objects are active, so nothing needs pinning).  Reported, in steps/s
(worlds x steps / s) over ``--steps`` steps captured in one CUDA graph:

  * ``jax``          : the same steps through MJX under JAX (``Simulator.settle``: our loop;
                       first variant only);
  * ``graph_nocond`` : MuJoCo Warp alone, solver loop unrolled to ``sim.iterations`` (this is
                       what MJX does under JAX: CUDA graph conditionals are off there);
  * ``graph_cond``   : MuJoCo Warp alone, solver loop as a CUDA-graph while loop that stops
                       when every world has converged (MuJoCo Warp's native mode);

the solver's mean and largest iteration count (the largest decides the cost: every world waits
for the slowest), and the event trace of one step (GPU ms per ``mjw.step`` phase, mean over the
captured steps) so the expensive phases are named, not guessed.
"""
from __future__ import annotations

import argparse
import platform
import sys
import time

import jax
import numpy as np

from timing import emit_row, parse_variant
from vags_jax import config as C
from vags_jax.sim.scene import build_scene
from vags_jax.sim.simulator import Simulator


def _flatten(trace: dict, prefix: str = "", depth: int = 0, out=None):
    out = [] if out is None else out
    for name, (events, sub) in trace.items():
        ms = float(np.mean(events)) if events else 0.0
        out.append((depth, prefix + name, ms, len(events)))
        _flatten(sub, prefix + name + "/", depth + 1, out)
    return out


def _time_warp(mjw, wp, warp_util, mjm, B, nacon, njmax, qpos, qvel, ctrl, steps, trace_depth):
    """MuJoCo Warp alone: steps/s with and without graph conditionals, solver iterations, trace."""
    row = {}
    for mode in ("graph_nocond", "graph_cond"):
        m = mjw.put_model(mjm)
        m.opt.graph_conditional = mode == "graph_cond"
        m.opt.warn_overflow = 0  # iteration-limit messages: we count the iterations ourselves
        d = mjw.make_data(mjm, nworld=B, naconmax=nacon, njmax=njmax)
        d.qpos.assign(qpos)
        d.qvel.assign(qvel)
        d.ctrl.assign(ctrl)
        mjw.step(m, d)  # load / compile kernels outside the graph
        wp.synchronize()
        with wp.ScopedCapture() as cap:
            for _ in range(steps):
                mjw.step(m, d)
        wp.capture_launch(cap.graph)  # warm
        wp.synchronize()
        t0 = time.perf_counter()
        wp.capture_launch(cap.graph)
        wp.synchronize()
        row[f"{mode}_steps_per_s"] = B * steps / (time.perf_counter() - t0)
        niter = d.solver_niter.numpy()
        row[f"{mode}_mean_solver_niter"] = float(np.mean(niter))
        row[f"{mode}_max_solver_niter"] = int(np.max(niter))
        row[f"{mode}_worlds_at_cap"] = int(np.sum(niter >= mjm.opt.iterations))
        if mode == "graph_nocond" and trace_depth >= 0:
            with warp_util.EventTracer() as tracer:
                with wp.ScopedCapture() as cap2:
                    for _ in range(steps):
                        mjw.step(m, d)
                wp.capture_launch(cap2.graph)
                wp.synchronize()
                trace = _flatten(tracer.trace())
            total = next((ms for dep, name, ms, n in trace if dep == 0), float("nan"))
            print(f"event trace ({mode}): GPU ms per call, mean over {steps} steps; % of step")
            for dep, name, ms, n in trace:
                if dep <= trace_depth:
                    print(f"{'  ' * dep}{name.split('/')[-1]:<40s} {ms:8.3f} ms  {100 * ms / total:5.1f} %"
                          f"  (x{n // steps})")
            row["trace_ms"] = {name: ms for dep, name, ms, n in trace if dep <= trace_depth}
    return row


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--worlds", type=int, default=4096)
    p.add_argument("--objects", type=int, default=10)
    p.add_argument("--steps", type=int, default=50)
    p.add_argument("--config", default="default")
    p.add_argument("--set", nargs="*", default=[], help="config overrides for every variant")
    p.add_argument("--variant", action="append", default=None,
                   help="name:override;override (repeatable; sim.* settings); default: 'default:'")
    p.add_argument("--trace-depth", type=int, default=3, help="event-trace depth (-1: no trace)")
    p.add_argument("--out", default=None, help="append the rows as JSON lines here")
    args = p.parse_args(argv)

    import warp as wp
    import mujoco.mjx.third_party.mujoco_warp as mjw
    from mujoco.mjx.third_party.mujoco_warp._src import warp_util

    base = C.replace(C.preset(args.config), **C.parse_overrides(args.set), **{"sim.impl": "warp"})
    sim = Simulator(base, build_scene(base))
    B = args.worlds
    print(f"device: {jax.devices()[0].device_kind}, jax {jax.__version__}, warp {wp.__version__}, "
          f"{platform.node()}; nv={sim.nv}, worlds={B}", flush=True)
    state = jax.block_until_ready(sim.reset(jax.random.PRNGKey(0), np.full(B, args.objects)))
    seconds = args.steps * base.sim.timestep
    jax.block_until_ready(sim.settle(state, seconds))  # compile
    t0 = time.perf_counter()
    jax.block_until_ready(sim.settle(state, seconds))
    t_jax = time.perf_counter() - t0
    qpos = np.asarray(state.data.qpos, np.float32)
    qvel = np.asarray(state.data.qvel, np.float32)
    ctrl = np.asarray(state.data.ctrl, np.float32)

    rows = []
    for i, v in enumerate(args.variant or ["default:"]):
        name, overrides = parse_variant(v)
        cfg = C.replace(base, **C.parse_overrides(overrides))
        scene = build_scene(cfg)
        vsim = Simulator(cfg, scene)
        if vsim.nq != sim.nq:
            print(f"{name}: skipped, the override changes the model's coordinates", flush=True)
            continue
        nacon, njmax = vsim.buffer_sizes(B)
        row = {"variant": name, "overrides": args.set + overrides, "worlds": B, "nv": sim.nv,
               "steps": args.steps, "naconmax": nacon, "njmax": njmax}
        if i == 0:
            row["jax_steps_per_s"] = B * args.steps / t_jax
        print(f"\n== {name} {overrides}", flush=True)
        row.update(_time_warp(mjw, wp, warp_util, scene.mj_model, B, nacon, njmax, qpos, qvel, ctrl,
                              args.steps, args.trace_depth))
        rows.append(row)
        emit_row(row, args.out)
    print("\n| variant | steps/s, JAX-like (no graph conditionals) | steps/s, native | mean / max solver iterations | worlds at the cap |")
    print("|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['variant']} | {r['graph_nocond_steps_per_s']:,.0f} | {r['graph_cond_steps_per_s']:,.0f} | "
              f"{r['graph_nocond_mean_solver_niter']:.2f} / {r['graph_nocond_max_solver_niter']} | "
              f"{r['graph_nocond_worlds_at_cap']} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
