"""The devices of data-parallel training: how many (``train.py --devices N|all``), the 1-D mesh
over them, and ``jax.distributed`` for a run over several hosts (``--distributed``).

Several hosts: ``initialize_distributed`` must run before JAX touches a device; afterwards
``jax.devices()`` lists every host's devices and the mesh spans them.  That path is written
for it but has not been run on more than one host (README, "Several devices").
"""
from __future__ import annotations

import os
from typing import Union

import jax
import numpy as np
from jax.sharding import Mesh

from vags_jax.parallel.collectives import AXIS


def initialize_distributed() -> None:
    """``jax.distributed.initialize()`` from the cluster's environment: a cluster manager JAX
    detects itself (SLURM, Open MPI), or JAX_COORDINATOR_ADDRESS (host:port of process 0) with
    JAX_NUM_PROCESSES and JAX_PROCESS_ID, passed on here.  ValueError with JAX's first line when
    it fails."""
    kwargs = {}
    for env, arg in (("JAX_NUM_PROCESSES", "num_processes"), ("JAX_PROCESS_ID", "process_id")):
        if os.environ.get(env):
            try:
                kwargs[arg] = int(os.environ[env])
            except ValueError:
                raise ValueError(f"--distributed: {env}={os.environ[env]!r} is not an integer") from None
    try:
        jax.distributed.initialize(**kwargs)
    except (RuntimeError, ValueError) as e:
        first = (str(e).strip().splitlines() or [type(e).__name__])[0]
        raise ValueError(f"--distributed: jax.distributed.initialize() failed ({first[:200]}); run one process "
                         f"per host under a cluster manager JAX knows (SLURM, Open MPI) or set "
                         f"JAX_COORDINATOR_ADDRESS, JAX_NUM_PROCESSES and JAX_PROCESS_ID") from None


def resolve(asked: Union[int, str]) -> int:
    """``--devices`` -> a device count: "all" is every device JAX sees (every host's with
    ``--distributed``); a number must not exceed them (ValueError saying what there is)."""
    have, platform = jax.device_count(), jax.devices()[0].platform
    n = have if asked == "all" else int(asked)
    if n > have:
        raise ValueError(f"--devices {asked} asks for more devices than the {have} {platform} device(s) JAX sees "
                         f"here; pass --devices {have} (or all), or fewer")
    return n


def make_mesh(n: int) -> Mesh:
    """A 1-D mesh over the first ``n`` devices, its one axis named ``AXIS`` ("data")."""
    devices = jax.devices()
    if n > len(devices):
        raise ValueError(f"a mesh of {n} devices needs {n}, JAX sees {len(devices)}")
    return Mesh(np.asarray(devices[:n]), (AXIS,))


__all__ = ["initialize_distributed", "resolve", "make_mesh", "AXIS"]
