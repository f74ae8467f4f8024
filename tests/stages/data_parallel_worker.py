"""Run by tests/stages/test_data_parallel.py in one subprocess whose JAX has 2 virtual CPU devices
(``XLA_FLAGS=--xla_force_host_platform_device_count=2``, set before JAX starts).  ``update`` and
``env`` compute the same thing on one device and split over the 2-device mesh and report the
largest differences; ``train`` runs ``train.py --devices 2`` in this process (2 iterations, resumed
to 4, and 4 in one go, sharing one ``driver.Programs`` as test_stages.py's pipeline does; and
``--devices 3``, which is refused).  All
results are printed as one JSON line for the tests to judge: one process, one JAX start.

    python tests/stages/data_parallel_worker.py OUT_DIR
"""
import contextlib
import io
import json
import os
import sys

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import PartitionSpec as P

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, ROOT)
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from conftest import PYRAMIDAL, TINY_TEST_OVERRIDES  # noqa: E402  (and the session's compile cache)
from vags_jax import config as C  # noqa: E402
from vags_jax.env import VagsEnv  # noqa: E402
from vags_jax.nets import init_qnet, make_qnet  # noqa: E402
from vags_jax.parallel.collectives import AXIS  # noqa: E402
from vags_jax.parallel.mesh import make_mesh  # noqa: E402
from vags_jax.rl import dqn, replay  # noqa: E402
from vags_jax.stages import data_parallel  # noqa: E402


# The tiny test config on conftest's PYRAMIDAL cones (as the tests' train.py --set lists).
TEST_OVERRIDES = {**TINY_TEST_OVERRIDES, **C.parse_overrides(PYRAMIDAL)}


def max_diff(a, b) -> float:
    """Largest absolute difference over two pytrees of arrays of the same structure."""
    return max(float(np.max(np.abs(np.asarray(x, np.float64) - np.asarray(y, np.float64))))
               for x, y in zip(jax.tree.leaves(a), jax.tree.leaves(b)))


def check_update() -> dict:
    """One DQN update of GDNet (executed rotation only, BatchNorm in train mode) on a batch of
    8: on one device, and with 4 samples on each of 2 devices (pmean'd gradients and BatchNorm
    statistics)."""
    # SGD: its step is proportional to the gradient, so a gradient of the wrong scale shows.
    cfg = C.replace(C.tiny(), **{**TINY_TEST_OVERRIDES, "dqn.batch_size": 8, "dqn.target_update_period": 1,
                                 "dqn.optimizer": "sgd", "dqn.learning_rate": 0.05})
    H, R, b = cfg.workspace.heightmap_px, cfg.net.n_rotations, cfg.dqn.batch_size
    ts = dqn.create_train_state(init_qnet(jax.random.PRNGKey(0), make_qnet(cfg.net, "gdnet"), H, H), cfg.dqn)
    k = jax.random.split(jax.random.PRNGKey(1), 6)
    batch = replay.make_grasp_transition(
        jax.random.randint(k[0], (b, H, H, 3), 0, 256), jax.random.uniform(k[1], (b, H, H), maxval=0.08),
        jnp.stack([jax.random.randint(k[2], (b,), 0, R), jax.random.randint(k[3], (b,), 0, H),
                   jax.random.randint(k[4], (b,), 0, H)], 1),
        (jnp.arange(b) % 2).astype(jnp.float32), jax.random.randint(k[5], (b, H, H, 3), 0, 256),
        jax.random.uniform(k[1], (b, H, H), maxval=0.05), jnp.arange(b) % 3 == 0)
    weights = jnp.linspace(0.5, 1.0, b)

    def updater(axis):
        net = make_qnet(cfg.net, "gdnet", axis)
        apply = lambda v, c, h, t, mutable=False, rotations=None: net.apply(  # noqa: E731
            v, c, h, t, rotations=rotations, mutable=mutable)
        return dqn.make_update_step(apply, cfg.dqn, executed_rotation_only=True, axis_name=axis)

    ts1, m1, td1 = jax.jit(updater(None))(ts, batch, weights)
    mesh = make_mesh(2)
    split = jax.jit(jax.shard_map(updater(AXIS), mesh=mesh, in_specs=(P(), P(AXIS), P(AXIS)),
                                  out_specs=(P(), P(), P(AXIS)), check_vma=False))
    ts2, m2, td2 = split(ts, batch, weights)
    return {"params": max_diff(ts1.params, ts2.params),
            "params_moved": max_diff(ts1.params, ts.params),
            "batch_stats": max_diff(ts1.batch_stats, ts2.batch_stats),
            "batch_stats_moved": max_diff(ts1.batch_stats, ts.batch_stats),
            "opt_state": max_diff(ts1.opt_state, ts2.opt_state),
            "target_params": max_diff(ts1.target_params, ts2.target_params),
            "loss": abs(float(m1["loss"]) - float(m2["loss"])), "loss_value": float(m1["loss"]),
            "grad_norm": abs(float(m1["grad_norm"]) - float(m2["grad_norm"])),
            "td": max_diff(td1, td2)}


def colour_differences(a, b, edge: float = 2e-3) -> dict:
    """Colour heightmap cells (any channel) that differ between states a and b: ``color_cells``
    all of them, ``color_cells_off_edges`` those not on a boundary between surfaces in either
    state (within one cell, diagonals included, of a colour change or a height step above
    ``edge`` m), where a sub-millimetre shift of the scene cannot change what a cell sees."""
    differ = np.any(np.asarray(a.color) != np.asarray(b.color), axis=-1)  # (B, H, W)
    boundary = np.zeros_like(differ)
    for s in (a, b):
        h, c = np.asarray(s.height), np.asarray(s.color).astype(np.int32)
        for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
            h2, c2 = np.roll(h, (-dr, -dc), (1, 2)), np.roll(c, (-dr, -dc), (1, 2))
            step = (np.abs(h - h2) > edge) | np.any(c != c2, axis=-1)
            boundary |= step | np.roll(step, (dr, dc), (1, 2))  # both cells of each neighbouring pair
    return {"color_cells": int(differ.sum()), "color_cells_off_edges": int((differ & ~boundary).sum()),
            "cells": int(differ.size)}


def train_config(iterations: int = 2):
    """The config ``train.py --devices 2`` builds from ``check_train``'s flags (``sets``)."""
    return C.replace(C.tiny(), **{**TEST_OVERRIDES, "stage1.iterations": iterations, "parallel.devices": 2})


def start_worlds(programs) -> object:
    """2 fresh worlds (one per device) from the init of the data-parallel stage that
    ``check_train`` trains with (``programs``): its reset program, compiled once for both checks
    instead of a second unsharded reset -> an ``EnvState`` of 2 worlds."""
    stage = programs.stage("stage1", train_config())
    state = stage.init(jax.random.PRNGKey(3)).env  # (device, world, ...)
    return jax.tree.map(lambda x: jnp.asarray(x).reshape((2,) + x.shape[2:]), state)


def check_env(programs) -> dict:
    """One grasp step of 2 worlds (MJX impl "jax": physics, render, heightmaps, round
    bookkeeping; no reset, no sensor noise) from the same start (``start_worlds``): unsharded,
    with one world on each of 2 devices through the data-parallel stage's layout (a leading
    device axis, ``data_parallel.stack`` / ``unstack`` under ``jax.shard_map``)."""
    cfg = C.replace(C.tiny(), **{**TEST_OVERRIDES, "camera.noise.enabled": False})
    env = VagsEnv(cfg)
    H, B = cfg.workspace.heightmap_px, 2
    state = start_worlds(programs)
    flat = state.height.reshape(B, -1)
    top = jnp.argmax(flat, axis=1)  # each world's highest cell: a grasp on an object
    pixel = jnp.stack([top // H, top % H], 1).astype(jnp.int32)
    rotation = jnp.array([0, 4], jnp.int32)
    no_reset, n_objects = jnp.zeros((B,), bool), jnp.ones((B,), jnp.int32)
    key = jax.random.PRNGKey(4)

    def step(s, pixel, rotation, no_reset, n_objects):
        return env.step_grasp_or_reset(s, pixel, rotation, no_reset, key, n_objects)

    one_state, one_result = jax.jit(step)(state, pixel, rotation, no_reset, n_objects)

    def local(s, pixel, rotation, no_reset, n_objects):
        args = data_parallel.unstack((s, pixel, rotation, no_reset, n_objects))
        return data_parallel.stack(step(*args))

    per_device = lambda x: x.reshape((2, B // 2) + x.shape[1:])  # noqa: E731  (device, world, ...)
    split = jax.jit(jax.shard_map(local, mesh=make_mesh(2), in_specs=P(AXIS), out_specs=P(AXIS), check_vma=False))
    two_state, two_result = split(*jax.tree.map(per_device, (state, pixel, rotation, no_reset, n_objects)))
    merge = lambda t: jax.tree.map(lambda x: x.reshape((B,) + x.shape[2:]), t)  # noqa: E731
    two_state, two_result = merge(two_state), merge(two_result)
    return {"success_one": np.asarray(one_result.success).tolist(),
            "success_two": np.asarray(two_result.success).tolist(),
            "qpos": max_diff(one_state.sim.data.qpos, two_state.sim.data.qpos),
            "qpos_moved": max_diff(one_state.sim.data.qpos, state.sim.data.qpos),
            "height": max_diff(one_state.height, two_state.height),
            **colour_differences(one_state, two_state),
            "attempts": max_diff(one_state.attempts, two_state.attempts),
            "remaining": [np.asarray(env.n_remaining(x)).tolist() for x in (one_state, two_state)]}


def check_train(out_dir: str, programs) -> dict:
    """``train.py --stage gdnet --devices 2`` on the tiny test config: 2 iterations into
    OUT_DIR/dp, then ``--resume`` to 4 (the device count read from its config.json), and 4 in
    one go into OUT_DIR/dp_straight, and --devices 3 ("too_many", with its stdout) -> {name: {"code",
    "stderr"}}; the test reads the runs."""
    import train

    sets = lambda n: [f"{k}={v}" for k, v in {**TINY_TEST_OVERRIDES, "stage1.iterations": n}.items()] + PYRAMIDAL  # noqa: E731
    out, straight = os.path.join(out_dir, "dp"), os.path.join(out_dir, "dp_straight")
    runs = {"first": ["--config", "tiny", "--stage", "gdnet", "--devices", "2", "--chunk", "2", "--quiet",
                      "--out", out, "--set"] + sets(2),
            "resumed": ["--out", out, "--resume", "--stage", "gdnet", "--chunk", "2", "--quiet",
                        "--set", "stage1.iterations=4"],
            "once": ["--config", "tiny", "--stage", "gdnet", "--devices", "2", "--chunk", "2", "--quiet",
                     "--out", straight, "--set"] + sets(4)}
    got = {}
    for name, argv in runs.items():
        err = io.StringIO()
        with contextlib.redirect_stderr(err):
            code = train.main(argv, programs)
        got[name] = {"code": code, "stderr": err.getvalue()}
    # --devices 3 for 2 worlds on these 2 devices: refused in one line (stdout kept too), before
    # anything is built (here rather than in a train.py process of its own: one JAX start less).
    out_, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out_), contextlib.redirect_stderr(err):
        code = train.main(["--config", "tiny", "--stage", "gdnet", "--devices", "3", "--out",
                           os.path.join(out_dir, "three"), "--set"]
                          + [f"{k}={v}" for k, v in {**TINY_TEST_OVERRIDES, "stage1.iterations": 2}.items()])
    got["too_many"] = {"code": code, "stdout": out_.getvalue(), "stderr": err.getvalue()}
    return got


if __name__ == "__main__":
    assert jax.device_count() == 2, f"needs 2 devices (XLA_FLAGS), JAX sees {jax.device_count()}"
    from vags_jax.stages import driver

    shared = driver.Programs()  # check_env's start worlds come from the stage check_train trains
    print(json.dumps({"update": check_update(), "env": check_env(shared), "train": check_train(sys.argv[1], shared),
                      "stage_programs": sorted(k[0] for k in shared._built)}))
