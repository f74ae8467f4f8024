"""Which part of the data-parallel stage-1 chunk crashes XLA's GPU compiler (issue 27).

On two H100s, compiling ``DataParallelStage1``'s chunk segfaults inside XLA
(bench/RESULTS.md, "Data-parallel stage 1 on two H100s").  This script compiles the chunk and
pieces of it under ``jax.shard_map`` on the first two local devices, each variant in its own
process (a segfault kills only that one), and prints one Markdown row per variant:

    python bench/data_parallel_parts.py                 # every variant, one process each
    python bench/data_parallel_parts.py chunk           # one variant, in this process

Variants (the ``gpu`` preset with MJX impl "jax", 16 worlds, replay 1,024, batch 16, so that
only the program's structure matters):

* ``chunk``: the whole chunk (``DataParallelStage1._run_jit``, 1 iteration);
* ``chunk_f32``: the same with float32 networks (the preset's are bfloat16);
* ``no_learn``: the chunk with the DQN updates and the replay sampling cut out;
* ``learn_only``: only the updates (replay sampling, ``dqn.learn_from_replay`` with pmean'd
  gradients and BatchNorm statistics) over the replay shards;
* ``forward_only``: GDNet's forward pass on every world and the grasp choice;
* ``grasp_only`` / ``observe_only`` / ``grasp_observe``: one grasp-or-reset physics loop of every
  world, the render and heightmaps of every world, or both (the chunk's environment step);
* ``observe_nokey`` / ``observe_plainkey``: the render and heightmaps without sensor noise, or
  with the replicated key instead of the per-device one; ``device_key_only``: only the
  per-device key (``collectives.device_key``: ``axis_index`` folded into the key);
  ``identity_env``: the world state passed through unchanged; ``identity_empty`` /
  ``identity_nonempty``: only its leaves of size 0, or only the others; ``unstack_empty`` /
  ``unstack_nonempty``: the same through ``unstack`` / ``stack`` (the device axis dropped and
  put back, as the chunk does); ``unstack_all``: every leaf, as a list, through them;
  ``identity_env_nokey``: ``identity_env`` without the (unused) key argument.

Nothing is run on the devices but the start program (fresh worlds and replay shards).
"""
from __future__ import annotations

import faulthandler
import json
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

VARIANTS = ("chunk", "chunk_f32", "no_learn", "learn_only", "forward_only", "grasp_only", "observe_only",
            "grasp_observe", "observe_nokey", "observe_plainkey", "device_key_only", "identity_env",
            "identity_empty", "identity_nonempty", "unstack_empty", "unstack_nonempty",
            "unstack_all", "identity_env_nokey")
SMALL = {"sim.impl": "jax", "sim.timestep": 0.002, "stage1.n_worlds": 16, "replay.capacity": 1024, "dqn.batch_size": 16,
         "stage1.learning_starts": 16, "parallel.devices": 2}


def compile_variant(name: str) -> float:
    """Lowers and compiles variant ``name`` on 2 devices -> seconds taken."""
    import jax
    import jax.numpy as jnp
    from jax.sharding import PartitionSpec as P

    from vags_jax import config as C
    from vags_jax.parallel.collectives import AXIS
    from vags_jax.rl import exploration
    from vags_jax.stages.data_parallel import DataParallelStage1, stack, unstack

    over = dict(SMALL, **({"net.dtype": "float32"} if name == "chunk_f32" else {}),
                **({"camera.noise.enabled": False} if name == "observe_nokey" else {}))
    cfg = C.replace(C.gpu(), **over)
    stage = DataParallelStage1(cfg)
    local = stage.local
    if name == "no_learn":  # the chunk without updates: learner and replay pass through
        local._learn = lambda learner, buffer, key: (learner, buffer, (jnp.float32(0), jnp.float32(0)), jnp.int32(0))
    state = stage.init(jax.random.PRNGKey(0))
    t0 = time.time()
    if name in ("chunk", "chunk_f32", "no_learn"):
        stage._run_jit.lower(state, 1).compile()
    elif name == "learn_only":
        def learn(learner, buffer, key):
            learner, buffer, (loss, _), _ = local._learn(learner, unstack(buffer), key)
            return learner, stack(buffer), loss

        jax.jit(stage._shard(learn, (P(), P(AXIS), P()), (P(), P(AXIS), P()))).lower(
            state.learner, state.replay, state.key).compile()
    elif name == "identity_env_nokey":
        jax.jit(stage._shard(lambda env: stack(unstack(env)), (P(AXIS),), P(AXIS))).lower(state.env).compile()
    elif name == "unstack_all":
        leaves = jax.tree.leaves(state.env)
        jax.jit(stage._shard(lambda xs: stack(unstack(xs)), (P(AXIS),), P(AXIS))).lower(leaves).compile()
    elif name in ("identity_empty", "identity_nonempty", "unstack_empty", "unstack_nonempty"):
        # The world state's leaves of size 0, or the others: passed through, or through unstack / stack.
        leaves = [x for x in jax.tree.leaves(state.env) if (x.size == 0) == name.endswith("_empty")]
        print(json.dumps({"leaves": len(leaves), "shapes": sorted({str(x.shape) for x in leaves})[:12]}), file=sys.stderr)
        fn = (lambda xs: xs) if name.startswith("identity") else (lambda xs: stack(unstack(xs)))
        jax.jit(stage._shard(fn, (P(AXIS),), P(AXIS))).lower(leaves).compile()
    elif name in ("observe_nokey", "observe_plainkey", "device_key_only", "identity_env"):
        from vags_jax.parallel import collectives

        def look(env, key):
            s = unstack(env)
            if name == "device_key_only":
                return jax.random.uniform(collectives.device_key(key, AXIS), (1, 4))
            if name == "identity_env":  # every leaf of the world state in and out
                return stack(s)
            return stack(local.env.with_observation(s, None if name == "observe_nokey" else key))

        out = P(AXIS)
        jax.jit(stage._shard(look, (P(AXIS), P()), out)).lower(state.env, state.key).compile()
    elif name in ("grasp_only", "observe_only", "grasp_observe"):
        from vags_jax.parallel import collectives

        def step(env, key):
            s, k = unstack(env), collectives.device_key(key, AXIS)
            if name != "observe_only":
                H = cfg.workspace.heightmap_px
                b = s.height.shape[0]
                pixel = jnp.stack([jnp.arange(b) % H, jnp.arange(b) % H], 1).astype(jnp.int32)
                s, _ = local.env.step_grasp_or_reset(s, pixel, jnp.zeros((b,), jnp.int32), local.env.round_over(s), k,
                                                     jnp.ones((b,), jnp.int32), observe=False)
            if name != "grasp_only":
                s = local.env.with_observation(s, k)
            return stack(s)

        jax.jit(stage._shard(step, (P(AXIS), P()), P(AXIS))).lower(state.env, state.key).compile()
    else:  # forward_only
        def forward(learner, env, key):
            s = unstack(env)
            q = local._apply({"params": learner.params, "batch_stats": learner.batch_stats}, s.color, s.height, False)
            action, _ = exploration.select_grasp(key, q, s.height, 0.5, cfg.exploration)
            return stack(action)

        jax.jit(stage._shard(forward, (P(), P(AXIS), P()), P(AXIS))).lower(state.learner, state.env, state.key).compile()
    return time.time() - t0


def main() -> int:
    if len(sys.argv) > 1:
        name = sys.argv[1]
        if name not in VARIANTS:
            print(f"data_parallel_parts.py: unknown variant {name!r}; choose one of {VARIANTS}", file=sys.stderr)
            return 2
        faulthandler.enable()
        print(json.dumps({"variant": name, "compile_s": round(compile_variant(name), 1)}))
        return 0
    print("| variant | result | seconds |\n|---|---|---:|")
    for name in VARIANTS:
        t0 = time.time()
        p = subprocess.run([sys.executable, os.path.abspath(__file__), name], capture_output=True, text=True)
        result = "compiled" if p.returncode == 0 else (
            f"crashed (signal {-p.returncode})" if p.returncode < 0 else f"failed (exit {p.returncode})")
        print(f"| {name} | {result} | {time.time() - t0:.0f} |", flush=True)
        if p.returncode != 0:
            print("\n".join("    " + line for line in p.stderr.strip().splitlines()[-12:]), file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
