#!/usr/bin/env python3
"""How long XLA takes to compile GDNet's learner programs, and what one call then costs.

    python bench/compile_time.py --config paper --out OUT/default.json
    XLA_FLAGS=--xla_gpu_autotune_level=0 python bench/compile_time.py --config paper --out OUT/autotune0.json

Programs (this config's GDNet, random inputs of its heightmap size):
* ``update``: one DQN update (``vags_jax.rl.dqn.make_update_step``, executed rotation only, as
  the stages): the target network over every rotation of ``dqn.batch_size`` next states, the
  online network forward and backward, the optimizer step;
* ``forward``: the greedy pass over ``--worlds`` states x every rotation (the collect step's
  network work), in eval mode.

Each is lowered and compiled in this process; run as a command, JAX's persistent compile
cache is off (``persistent_cache`` in the report), so the figures are a cold start's.
``lower_s`` is tracing + lowering to StableHLO, ``compile_s`` XLA's compile (on a GPU it
includes autotuning; ``XLA_FLAGS`` is recorded), ``run_s`` the median of three calls after a
warm-up call, ``temp_bytes`` / ``argument_bytes`` XLA's buffer sizes (where the backend
reports them).  The stages compile these inside larger programs (a stage's chunk), so the sum
here is a lower bound of a chunk's compile.  Needs only jax, flax and optax: no physics.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def random_transitions(cfg, key, b: int):
    """``b`` random grasp transitions of this config's heightmap size (``GraspTransition``) and
    importance weights 1 (b,)."""
    import jax
    import jax.numpy as jnp

    from vags_jax.rl import replay

    H = cfg.workspace.heightmap_px
    k = jax.random.split(key, 5)
    color = jax.random.randint(k[0], (b, H, H, 3), 0, 256).astype(jnp.uint8)
    height = jax.random.uniform(k[1], (b, H, H), maxval=0.1)
    action = jnp.stack([jax.random.randint(k[2], (b,), 0, cfg.net.n_rotations),
                        jax.random.randint(k[3], (b,), 0, H), jax.random.randint(k[4], (b,), 0, H)], 1)
    t = replay.make_grasp_transition(color, height, action, jnp.ones((b,)), color, height, jnp.zeros((b,), bool))
    return t, jnp.ones((b,), jnp.float32)


def measure(jitted, *args) -> dict:
    """Lower, compile and time ``jitted(*args)``: seconds of each step."""
    import jax
    import numpy as np

    t = time.perf_counter()
    lowered = jitted.lower(*args)
    t_lower = time.perf_counter() - t
    t = time.perf_counter()
    compiled = lowered.compile()
    t_compile = time.perf_counter() - t
    jax.block_until_ready(compiled(*args))
    runs = []
    for _ in range(3):
        t = time.perf_counter()
        jax.block_until_ready(compiled(*args))
        runs.append(time.perf_counter() - t)
    out = {"lower_s": round(t_lower, 3), "compile_s": round(t_compile, 3), "run_s": float(np.median(runs)),
           "stablehlo_lines": lowered.as_text().count("\n")}
    memory = compiled.memory_analysis()  # None where the backend does not report it
    if memory is not None:
        out["temp_bytes"] = int(memory.temp_size_in_bytes)
        out["argument_bytes"] = int(memory.argument_size_in_bytes)
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--config", default="paper", help="preset (default: paper)")
    p.add_argument("--set", nargs="*", default=[], metavar="SECTION.FIELD=VALUE")
    p.add_argument("--worlds", type=int, default=None, help="states of the forward program (default: stage1.n_worlds)")
    p.add_argument("--programs", default="update,forward", help="comma-separated: update, forward")
    p.add_argument("--out", default=None, help="JSON report path")
    args = p.parse_args(argv)
    programs = [s for s in args.programs.split(",") if s]
    if not programs or set(programs) - {"update", "forward"}:
        p.error(f"--programs takes update and/or forward, got {args.programs!r}")
    if args.worlds is not None and args.worlds < 1:
        p.error(f"--worlds must be at least 1, got {args.worlds}")

    from vags_jax import config as C

    try:
        cfg = C.replace(C.preset(args.config), **C.parse_overrides(args.set))
    except ValueError as e:
        p.error(str(e))
    report = _measure_programs(args, cfg, programs)
    print(json.dumps(report))
    if args.out:
        os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
        with open(args.out, "w") as f:
            json.dump(report, f, indent=1)
    return 0


def _measure_programs(args, cfg, programs) -> dict:
    """The report: config, device and each program's ``measure``."""
    import jax

    from vags_jax.nets import initial_variables, make_qnet
    from vags_jax.rl import dqn

    H = cfg.workspace.heightmap_px
    net = make_qnet(cfg.net, "gdnet")
    apply = lambda v, c, h, train, mutable=False, rotations=None: net.apply(  # noqa: E731
        v, c, h, train, rotations=rotations, mutable=mutable)
    variables = initial_variables(jax.random.PRNGKey(0), net, cfg.net, H, H)
    report = {"config": args.config, "set": args.set, "trunk": cfg.net.trunk, "dtype": cfg.net.dtype,
              "heightmap_px": H, "rotations": cfg.net.n_rotations, "batch_size": cfg.dqn.batch_size,
              "xla_flags": os.environ.get("XLA_FLAGS", ""), "device": str(jax.devices()[0]),
              "jax": jax.__version__, "programs": {},
              # False from the command line (a cold start); True where a caller's cache may have served it
              "persistent_cache": bool(jax.config.jax_enable_compilation_cache and jax.config.jax_compilation_cache_dir)}
    if "update" in programs:
        learner = dqn.create_train_state(variables, cfg.dqn)
        update = dqn.make_update_step(apply, cfg.dqn, executed_rotation_only=True)
        batch, w = random_transitions(cfg, jax.random.PRNGKey(1), cfg.dqn.batch_size)
        report["programs"]["update"] = measure(jax.jit(lambda ts, b, w: update(ts, b, w)[:2]), learner, batch, w)
        print(f"update: {report['programs']['update']}", file=sys.stderr, flush=True)
    if "forward" in programs:
        n = cfg.stage1.n_worlds if args.worlds is None else args.worlds
        batch, _ = random_transitions(cfg, jax.random.PRNGKey(2), n)
        fwd = jax.jit(lambda v, c, h: apply(v, c, h, False))
        report["programs"]["forward"] = dict(measure(fwd, variables, batch.color, batch.height.astype("float32")),
                                             worlds=n)
        print(f"forward: {report['programs']['forward']}", file=sys.stderr, flush=True)
    return report


if __name__ == "__main__":
    import jax

    jax.config.update("jax_enable_compilation_cache", False)  # before any compile: nothing comes from a cache
    sys.exit(main())
