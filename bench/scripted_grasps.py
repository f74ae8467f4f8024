#!/usr/bin/env python3
"""Scripted grasp outcomes at scale: does a physics setting still tell good grasps from bad?

    python bench/scripted_grasps.py --impl warp --worlds 2048 --variant base: \\
        --variant 'dt4:sim.timestep=0.004' --out bench/results/scripted.jsonl

The scenes are the tests' (``tests/grasp_scenarios.py``): isolated cubes grasped at their centre
with a face-normal yaw (should succeed), empty spots (must fail) and 10 cm cuboids grasped with
the closing axis along their length, wrong by 90 degrees (must fail).  Positions and yaws are
random.  One jitted grasp call per variant over all worlds; reported per scenario: the success
rate, errors (NaN / tunnelling) and overflows, plus the physics steps per grasp.  A setting that
speeds up the physics must keep cubes near 100 % and the other two at 0 %.
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import jax
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests"))
from grasp_scenarios import scenarios, tiny_config  # noqa: E402
from timing import emit_row, parse_variant  # noqa: E402
from vags_jax import config as C  # noqa: E402
from vags_jax.sim.scene import build_scene  # noqa: E402
from vags_jax.sim.simulator import Simulator  # noqa: E402


def run_variant(impl: str, n_worlds: int, overrides: list[str], seed: int) -> dict:
    n_cube = n_worlds // 2
    n_empty = n_worlds // 4
    n_long = n_worlds - n_cube - n_empty
    cfg = tiny_config(**{"sim.impl": impl, **C.parse_overrides(overrides)})
    sim = Simulator(cfg, build_scene(cfg))
    sc = scenarios(n_cube, n_empty, n_long, sim.P, cfg, seed=seed)
    state = sim.set_objects(sim.empty(n_worlds), sc["pos"], sc["quat"], sc["active"])
    t0 = time.perf_counter()
    new, res = jax.block_until_ready(sim.grasp_at(state, sc["position"], sc["yaw"]))
    s = np.asarray(res.success)
    parts = {"cube": slice(0, n_cube), "empty": slice(n_cube, n_cube + n_empty),
             "long_wrong_axis": slice(n_cube + n_empty, n_worlds)}
    return {
        "impl": impl, "worlds": n_worlds, "physics_steps_per_grasp": sim.n_grasp_steps,
        **{f"success_{k}": float(s[v].mean()) for k, v in parts.items()},
        **{f"n_{k}": int(v.stop - v.start) for k, v in parts.items()},
        "errors": int(np.asarray(new.error).sum()), "overflows": int(np.asarray(new.overflow).sum()),
        "first_call_s_incl_compile": time.perf_counter() - t0,
    }


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--impl", default="jax", choices=["jax", "warp"])
    p.add_argument("--worlds", type=int, default=64, help="split 2:1:1 into cubes, empty spots, long cuboids")
    p.add_argument("--variant", action="append", default=[], metavar="NAME:A=1;B=2")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", default=None, help="append the rows (JSON lines) here")
    args = p.parse_args(argv)
    if args.worlds < 4:
        p.error("--worlds must be at least 4 (cubes, empty spots and long cuboids)")
    print(f"device: {jax.devices()[0].device_kind} ({jax.default_backend()}), jax {jax.__version__}", flush=True)
    for name, ov in [parse_variant(v) for v in args.variant] or [("", [])]:
        emit_row({"variant": name, "overrides": ov, **run_variant(args.impl, args.worlds, ov, args.seed)}, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
