#!/usr/bin/env python3
"""MJX steps on the CPU with the Cholesky factorisations and triangular solves lowered as this
package does (``--lowering package``: ``vags_jax.sim.cpu_linalg``), always to XLA's own algorithms
(``xla``) or always to jaxlib's LAPACK kernels (``lapack``, JAX's default, which deadlocks on a
2-core machine from 64 worlds: bench/RESULTS.md, "The CPU physics deadlock"; run it under
``timeout``).  One process per lowering; compare the lines they print.

    python bench/cpu_linalg_speed.py --worlds 8 --steps 200 --lowering xla
    timeout 120 python bench/cpu_linalg_speed.py --worlds 8 --steps 200 --lowering lapack

The model is a damped 6-dof gripper (3 slides, 3 hinges) over three free boxes on a plane: nv = 24,
as in the ``tiny`` preset's worlds of 3 objects, so each step factorises 24 x 24 matrices.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time

import jax
import jax.numpy as jnp
import mujoco
from mujoco import mjx

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

XML = """
<mujoco>
  <option timestep="0.002"/>
  <worldbody>
    <geom type="plane" size="1 1 0.1"/>
    <body pos="0 0 0.4">
      <joint type="slide" axis="1 0 0" damping="5"/><joint type="slide" axis="0 1 0" damping="5"/>
      <joint type="slide" axis="0 0 1" damping="5"/><joint type="hinge" axis="1 0 0" damping="1"/>
      <joint type="hinge" axis="0 1 0" damping="1"/><joint type="hinge" axis="0 0 1" damping="1"/>
      <geom type="box" size="0.05 0.02 0.02" mass="0.5"/>
    </body>
    <body pos="0 0 0.05"><freejoint/><geom type="box" size="0.03 0.03 0.03"/></body>
    <body pos="0.1 0 0.05"><freejoint/><geom type="box" size="0.03 0.03 0.03"/></body>
    <body pos="0.05 0.1 0.05"><freejoint/><geom type="box" size="0.03 0.03 0.03"/></body>
  </worldbody>
</mujoco>
"""


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--worlds", type=int, default=8)
    p.add_argument("--steps", type=int, default=200, help="steps per timed call (one lax.scan)")
    p.add_argument("--reps", type=int, default=5)
    p.add_argument("--lowering", choices=("package", "xla", "lapack"), default="package",
                   help="package: as vags_jax.sim lowers them; xla: XLA's algorithms for every batch; "
                   "lapack: jaxlib's LAPACK kernels (JAX's default)")
    args = p.parse_args(argv)
    if args.lowering != "lapack":
        from vags_jax.sim import cpu_linalg
        cpu_linalg.use_xla_linalg_on_cpu(0 if args.lowering == "xla" else cpu_linalg.LAPACK_MAX_BATCH)
    model = mjx.put_model(mujoco.MjModel.from_xml_string(XML))
    data = jax.vmap(lambda _: mjx.make_data(model))(jnp.arange(args.worlds))

    @jax.jit
    def run(d):
        return jax.lax.scan(lambda d, _: (jax.vmap(lambda x: mjx.step(model, x))(d), None), d, None,
                            length=args.steps)[0]

    text = run.lower(data).as_text()
    t0 = time.perf_counter()
    jax.block_until_ready(run(data))
    first = time.perf_counter() - t0
    times = []
    for _ in range(args.reps):
        t0 = time.perf_counter()
        jax.block_until_ready(run(data))
        times.append(time.perf_counter() - t0)
    best = min(times)
    print(json.dumps({"lowering": args.lowering, "lapack_calls": text.count("lapack_"),
                      "worlds": args.worlds, "steps": args.steps, "compile_and_first_s": round(first, 2),
                      "best_s": round(best, 4), "ms_per_step": round(1000 * best / args.steps, 3),
                      "device": str(jax.devices()[0])}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
