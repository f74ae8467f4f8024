#!/usr/bin/env python3
"""First grasps in fresh scenes: how many worlds a physics setting sends to NaN, and how many grasp.

    python bench/first_grasps.py --config tiny --worlds 48 --key 3 --variant base: --variant 'imp1:sim.impratio=1'

For each ``--variant`` (``name:override;override``, on top of ``--set``): ``VagsEnv.reset`` draws
``--worlds`` scenes of ``--objects`` objects with PRNG key ``--key`` (the same draws for every
variant), then every world makes one grasp chosen by the scripted ``heuristic`` policy (highest
object, narrowest closing axis) from its global heightmap.  Reported: the worlds whose physics
failed (NaN or an object through the table: ``SimState.error``), which ones, the successes,
and the wall time of the whole variant (compile included).  Runs on any device; the CPU
figures in bench/RESULTS.md come from it.
"""
from __future__ import annotations

import argparse
import sys
import time

import jax
import numpy as np

from timing import emit_row, parse_variant
from vags_jax import config as C
from vags_jax.env import VagsEnv
from vags_jax.policies.catalog import min_width_grasp


def run_variant(cfg: C.Config, n_worlds: int, n_objects: int, key: int) -> dict:
    t0 = time.perf_counter()
    env = VagsEnv(cfg)
    state = env.reset(jax.random.PRNGKey(key), np.full(n_worlds, n_objects))
    action, _ = min_width_grasp(state.height, cfg)  # (B, 3) [rotation, row, col]
    new, res = env.step_grasp(state, action[:, 1:], action[:, 0], jax.random.PRNGKey(1))  # key: sensor noise
    err = np.asarray(new.sim.error)
    return {
        "impl": cfg.sim.impl, "worlds": n_worlds, "objects": n_objects, "key": key,
        "errors": int(err.sum()), "error_worlds": np.nonzero(err)[0].tolist(),
        "successes": int(np.asarray(res.success).sum()),
        "overflows": int(np.asarray(new.sim.overflow).sum()),
        "wall_s_incl_compile": time.perf_counter() - t0,
    }


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--config", default="tiny", help="preset")
    p.add_argument("--set", nargs="*", default=[], help="config overrides section.field=value")
    p.add_argument("--worlds", type=int, default=48)
    p.add_argument("--objects", type=int, default=3)
    p.add_argument("--key", type=int, default=3)
    p.add_argument("--variant", action="append", default=[], metavar="NAME:A=1;B=2")
    p.add_argument("--out", default=None, help="append the rows (JSON lines) here")
    args = p.parse_args(argv)
    base = C.replace(C.preset(args.config), **C.parse_overrides(args.set))
    if not 1 <= args.objects <= base.scene.max_objects:
        p.error(f"--objects must be in 1..{base.scene.max_objects} (scene.max_objects of this config)")
    print(f"device: {jax.devices()[0].device_kind} ({jax.default_backend()}), jax {jax.__version__}", flush=True)
    for spec in args.variant or ["default:"]:
        name, overrides = parse_variant(spec)
        cfg = C.replace(base, **C.parse_overrides(overrides))
        row = run_variant(cfg, args.worlds, args.objects, args.key)
        emit_row({"variant": name, "config": args.config, "overrides": args.set + overrides, **row}, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
