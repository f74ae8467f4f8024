"""Run a batched function over a large batch in fixed-size groups, to bound peak memory.

``map_in_groups(fn, args, group)`` evaluates ``fn`` on ``group`` items at a time with
``lax.map`` (one compiled body, groups run one after another), padding the last group with
copies of the last item.  Used for rendering (``camera.render_batch``) and for the Q-networks'
inference over many worlds (``net.forward_batch``): GDNet's 16 rotations of 512 worlds at once
need tens of GB of activations.
"""
from __future__ import annotations

from typing import Callable

import jax
import jax.numpy as jnp


def map_in_groups(fn: Callable, args: tuple, group: int):
    """``fn(*args)`` over the leading axis B of every leaf of ``args`` in groups of ``group``
    -> the output pytree with leading axis B, as ``fn(*args)`` would give it.  A ``group`` of
    0 or at least B calls ``fn`` once on everything."""
    leaves = jax.tree.leaves(args)
    B = leaves[0].shape[0]
    if group <= 0 or B <= group:
        return fn(*args)
    n = -(-B // group)
    pad = n * group - B

    def grouped(a):
        if pad:
            a = jnp.concatenate([a, jnp.repeat(a[-1:], pad, 0)])
        return a.reshape((n, group) + a.shape[1:])

    out = jax.lax.map(lambda xs: fn(*xs), jax.tree.map(grouped, args))
    return jax.tree.map(lambda x: x.reshape((n * group,) + x.shape[2:])[:B], out)


__all__ = ["map_in_groups"]
