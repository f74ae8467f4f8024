"""Run a batched function over a large batch in fixed-size groups, to bound peak memory.

``map_in_groups(fn, args, group)`` evaluates ``fn`` on ``group`` items at a time with
``lax.map`` (one compiled body, groups run one after another), padding the last group with
copies of the last item.  Used for rendering (``camera.render_batch``) and for the Q-networks'
inference over many worlds (``net.forward_batch``): GDNet's 16 rotations of 512 worlds at once
need tens of GB of activations.

``map_in_groups_where(fn, args, group, need)`` does the same for the items ``need`` marks only:
they are gathered to the front, ``fn`` runs on as many groups as they fill (the other groups'
bodies are skipped by ``lax.cond``), and the other items' outputs are zeros.  The training
stages use it so that worlds that explore or reset make no Q-network pass (``net.forward_needed_only``).
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


def map_in_groups_where(fn: Callable, args: tuple, group: int, need: jax.Array):
    """``fn(*args)`` on the items where ``need`` (B,) bool is True, in groups of ``group``
    -> the output pytree with leading axis B: ``fn``'s result where ``need``, zeros elsewhere.

    The needed items are moved to the front (a stable sort: their order is kept) and the
    groups are run one after another; a group with no needed item is skipped, so the cost is
    ``ceil(need.sum() / group)`` groups.  ``fn`` must treat items independently (no batch
    statistics): each needed item's output is then what ``fn(*args)`` gives it, up to the
    floating-point effects of a different batch.  A ``group`` of 0 or at least B is one group."""
    leaves = jax.tree.leaves(args)
    B = leaves[0].shape[0]
    if need.shape != (B,):
        raise ValueError(f"map_in_groups_where: need must have shape ({B},), got {need.shape}")
    group = B if group <= 0 else min(group, B)
    n = -(-B // group)
    pad = n * group - B
    order = jnp.argsort(~need, stable=True)  # needed items first
    if pad:  # padded slots repeat the last item and are never needed
        order = jnp.concatenate([order, jnp.full((pad,), order[-1], order.dtype)])
    n_need = need.sum()
    out_shape = jax.eval_shape(fn, *jax.tree.map(lambda a: jax.ShapeDtypeStruct((group,) + a.shape[1:], a.dtype),
                                                 args))

    def body(xs):
        i, items = xs
        return jax.lax.cond(i * group < n_need, lambda: fn(*items),
                            lambda: jax.tree.map(lambda s: jnp.zeros(s.shape, s.dtype), out_shape))

    grouped = jax.tree.map(lambda a: a[order].reshape((n, group) + a.shape[1:]), args)
    out = jax.lax.map(body, (jnp.arange(n), grouped))
    inverse = jnp.argsort(order[:B])  # position of each item in the sorted order

    def back(x):
        x = x.reshape((n * group,) + x.shape[2:])[inverse]
        return jnp.where(need.reshape((B,) + (1,) * (x.ndim - 1)), x, jnp.zeros((), x.dtype))

    return jax.tree.map(back, out)


__all__ = ["map_in_groups", "map_in_groups_where"]
