"""Collectives over the data-parallel mesh axis that are the identity on one device.

Code that runs per device under ``jax.shard_map`` (``vags_jax.stages.data_parallel``) calls these with
``axis`` = the mesh axis name; the same code on one device passes ``axis=None`` and gets its
inputs back unchanged, so the one-device program is exactly what it was before data
parallelism (no collective, no extra operation).
"""
from __future__ import annotations

from typing import Any, Optional

import jax

AXIS = "data"  # the one mesh axis: worlds, replay and batch are split along it


def total(x: Any, axis: Optional[str]) -> Any:
    """Sum over devices (e.g. counts of worlds) of a pytree."""
    return x if axis is None else jax.lax.psum(x, axis)


def mean(x: Any, axis: Optional[str]) -> Any:
    """Mean over devices (equal shares: the mean over all worlds / samples) of a pytree."""
    return x if axis is None else jax.lax.pmean(x, axis)


def largest(x: Any, axis: Optional[str]) -> Any:
    """Maximum over devices of a pytree."""
    return x if axis is None else jax.lax.pmax(x, axis)


def smallest(x: Any, axis: Optional[str]) -> Any:
    """Minimum over devices of a pytree."""
    return x if axis is None else jax.lax.pmin(x, axis)


def device_key(key: jax.Array, axis: Optional[str]) -> jax.Array:
    """This device's stream of a replicated key: ``fold_in(key, device index)`` ((2,) raw
    uint32), so that the worlds (and replay shards) of different devices draw differently."""
    return key if axis is None else jax.random.fold_in(key, jax.lax.axis_index(axis))
