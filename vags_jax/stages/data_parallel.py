"""Stage 1 trained data-parallel over a 1-D device mesh (``train.py --devices N``).

The global state is a ``Stage1State`` whose per-device parts (``stage1.PER_DEVICE``: ``env``
and ``replay``) carry a leading device axis, sharded over the mesh: device d holds its
``n_worlds / N`` worlds and its replay shard of ``capacity / N`` transitions (every leaf
``(N, ...)``); ``learner``, ``key``, ``iteration`` and ``attempts`` are replicated.

A chunk is ``jax.jit(jax.shard_map(Stage1._run_impl))`` of the per-device ``Stage1``
(``local_config``: ``n_worlds / N`` worlds, ``capacity / N``, ``batch_size / N``,
``learning_starts / N`` rounded up; ``axis_name`` = the mesh axis): each device steps, renders
and trains on its own worlds and replay, so the physics never leaves its device (MuJoCo Warp's
FFI call is one XLA cannot partition itself).  Its collectives: gradients and train-mode
BatchNorm statistics averaged (parameters and optimizer state stay identical), replay weights
normalised over the whole batch, updates gated until every shard holds its share of
``learning_starts``, metrics summed / averaged over all worlds.  Worlds draw from per-device
key streams (``collectives.device_key``), so a run on N devices is not the one-device run
split up: it is reproducible for a given N, and resumes only with the same N.
``check_vma=False``: the Warp FFI's outputs carry no varying-axis metadata.
"""
from __future__ import annotations

import dataclasses
from functools import partial
from typing import Optional

import jax
import jax.numpy as jnp
from jax.sharding import NamedSharding, PartitionSpec as P

from vags_jax import config as C
from vags_jax.env import VagsEnv
from vags_jax.parallel.collectives import AXIS
from vags_jax.parallel.mesh import make_mesh
from vags_jax.rl import dqn
from vags_jax.stages.stage1 import PER_DEVICE, Stage1, Stage1State


def local_config(cfg: C.Config) -> C.Config:
    """One device's share of ``cfg`` for stage 1 over ``cfg.parallel.devices`` devices (the
    config checks that they divide evenly)."""
    d = cfg.parallel.devices
    return C.replace(cfg, **{
        "stage1.n_worlds": cfg.stage1.n_worlds // d, "replay.capacity": cfg.replay.capacity // d,
        "dqn.batch_size": cfg.dqn.batch_size // d, "stage1.learning_starts": -(-cfg.stage1.learning_starts // d),
        "parallel.devices": 1})


# Leaves of size 0 (MJX's empty constraint arrays) are made anew rather than sliced or reshaped:
# with both kinds in one shard_map program XLA's GPU compiler crashes (bench/RESULTS.md,
# "Where data parallel crashes").
def stack(tree):
    """One device's block of a per-device part: a leading axis of 1 on every leaf."""
    return jax.tree.map(lambda x: jnp.zeros((1,) + x.shape, x.dtype) if x.size == 0 else x[None], tree)


def unstack(tree):
    """The inverse of ``stack`` (under ``shard_map`` a device sees ``(1, ...)`` blocks)."""
    return jax.tree.map(lambda x: jnp.zeros(x.shape[1:], x.dtype) if x.size == 0 else x[0], tree)


def state_specs(state_cls, per_device=PER_DEVICE):
    """A prefix tree of ``PartitionSpec`` for a stage state dataclass: ``P(AXIS)`` (the leading
    device axis) on the ``per_device`` fields, ``P()`` (replicated) on the others."""
    return state_cls(**{f.name: P(AXIS) if f.name in per_device else P() for f in dataclasses.fields(state_cls)})


class DataParallelStage1:
    """Stage 1 over ``cfg.parallel.devices`` devices; the same ``init`` / ``run`` as ``Stage1``
    (``vags_jax.stages.pipeline.stage_fns``), on the global state described above."""

    def __init__(self, cfg: C.Config, env: Optional[VagsEnv] = None, mesh=None):
        self.cfg = cfg
        self.mesh = mesh if mesh is not None else make_mesh(cfg.parallel.devices)
        if self.mesh.size != cfg.parallel.devices:
            raise ValueError(f"a mesh of {self.mesh.size} devices for parallel.devices = {cfg.parallel.devices}")
        self.local = Stage1(local_config(cfg), env if env is not None else VagsEnv(cfg), axis_name=AXIS)
        self.env = self.local.env
        self.specs = state_specs(Stage1State)
        self.shardings = jax.tree.map(lambda p: NamedSharding(self.mesh, p), self.specs,
                                      is_leaf=lambda x: isinstance(x, P))
        replicated = NamedSharding(self.mesh, P())
        self._learner_jit = jax.jit(self.local.new_learner, out_shardings=replicated)
        self._init_jit = jax.jit(self._shard(self._init_local, (P(), P()), (P(AXIS), P(AXIS))))
        self._run_jit = jax.jit(self._run_impl, static_argnums=1)

    @property
    def n_worlds_per_device(self) -> int:
        return self.local.cfg.stage1.n_worlds

    def _shard(self, fn, in_specs, out_specs):
        return jax.shard_map(fn, mesh=self.mesh, in_specs=in_specs, out_specs=out_specs, check_vma=False)

    def _init_local(self, k_n, k_env):
        env_state, buffer = self.local.init_worlds(k_n, k_env)
        return stack(env_state), stack(buffer)

    def init(self, key: jax.Array, learner: Optional[dqn.TrainState] = None) -> Stage1State:
        """Fresh worlds and replay shards on every device and (unless given) a fresh GDNet
        learner, replicated; the keys are split as ``Stage1.init``'s."""
        k_net, k_n, k_env, k_loop = Stage1.init_keys(key)
        if learner is None:
            learner = self._learner_jit(k_net)
        self.env.prepare(self.n_worlds_per_device)  # caches built outside the trace
        env_state, buffer = self._init_jit(k_n, k_env)
        state = Stage1State(env=env_state, learner=learner, replay=buffer, key=k_loop,
                            iteration=jnp.zeros((), jnp.int32), attempts=jnp.zeros((), jnp.int32))
        return jax.device_put(state, self.shardings)

    def _run_local(self, state: Stage1State, n: int):
        per_device = {f: unstack(getattr(state, f)) for f in PER_DEVICE}
        state, metrics = self.local._run_impl(state.replace(**per_device), n)
        return state.replace(**{f: stack(getattr(state, f)) for f in PER_DEVICE}), metrics

    def _run_impl(self, state: Stage1State, n: int):
        return self._shard(partial(self._run_local, n=n), (self.specs,), (self.specs, P()))(state)

    def run(self, state: Stage1State, n: int):
        """Advance ``n`` iterations -> (state, metrics dict of (n,) float32 arrays, over all
        devices' worlds).  ``state`` may come from a checkpoint on one device: it is placed on
        the mesh first."""
        if not isinstance(n, int) or n < 1:
            raise ValueError(f"run: n must be a positive int, got {n!r}")
        self.env.prepare(self.n_worlds_per_device)
        return self._run_jit(jax.device_put(state, self.shardings), n)


__all__ = ["DataParallelStage1", "local_config", "state_specs", "stack", "unstack"]
