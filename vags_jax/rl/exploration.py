"""DAES (paper eq. 4): epsilon-greedy whose random pixel is drawn among object pixels.

With probability ``eps`` a world explores: a uniformly random pixel among the pixels whose
height exceeds ``Exploration.height_threshold`` (``daes=False``, the ablation: among all
pixels) and, for GDNet, a uniformly random rotation.  If a map has no object pixel, the pixel
is drawn uniformly over the whole map.  Otherwise the world takes the greedy argmax.

All functions are jittable (the config is static Python data), vmapped over the batch, and
keep everything on the device.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp

from vags_jax.config import Exploration


def epsilon(step, cfg: Exploration) -> jax.Array:
    """``max(eps_start * eps_decay**step, eps_end)``; ``step`` is a scalar or an array (e.g.
    per-world attempt counts), result has its shape, float32."""
    step = jnp.asarray(step, jnp.float32)
    return jnp.maximum(cfg.eps_start * jnp.power(jnp.float32(cfg.eps_decay), step), cfg.eps_end)


def random_object_cell(key: jax.Array, height: jax.Array, cfg: Exploration) -> jax.Array:
    """One map: height (H, W) -> flat pixel index () int32, uniform over object pixels (DAES),
    over all pixels when ``cfg.daes`` is False or the map has no object pixel."""
    flat = height.reshape(-1)
    if cfg.daes:
        mask = flat > cfg.height_threshold
        mask = jnp.where(jnp.any(mask), mask, True)
    else:
        mask = jnp.ones(flat.shape, jnp.bool_)
    logits = jnp.where(mask, 0.0, -jnp.inf)
    return jax.random.categorical(key, logits).astype(jnp.int32)


def _explore_mask(key: jax.Array, eps, batch: int) -> jax.Array:
    eps = jnp.broadcast_to(jnp.asarray(eps, jnp.float32), (batch,))
    return jax.random.uniform(key, (batch,)) < eps


def select_grasp(key: jax.Array, q: jax.Array, height: jax.Array, eps, cfg: Exploration):
    """GDNet action selection.

    key: PRNG key; q: (B, R, H, W) Q-values; height: (B, H, W) metres; eps: () or (B,).
    Returns ``action (B, 3) int32 [rotation, row, col]`` and ``explored (B,) bool``.
    """
    return select_grasp_from_greedy(key, greedy_grasp(q), q.shape[1], height, eps, cfg)


def greedy_grasp(q: jax.Array) -> jax.Array:
    """q (B, R, H, W) -> (B, 3) int32 [rotation, row, col] of each world's largest Q."""
    b, r, h, w = q.shape
    greedy_flat = jnp.argmax(q.reshape(b, -1), axis=-1)
    return jnp.stack(jnp.unravel_index(greedy_flat, (r, h, w)), axis=-1).astype(jnp.int32)


def select_grasp_from_greedy(key: jax.Array, greedy: jax.Array, n_rotations: int, height: jax.Array,
                             eps, cfg: Exploration):
    """``select_grasp`` given the greedy action (B, 3) [rotation, row, col] instead of the Q
    maps (stages 2 and 3 keep GDNet's argmax, not its (B, R, H, W) maps).  The same draws as
    ``select_grasp`` for the same key.  Returns ``action (B, 3) int32``, ``explored (B,) bool``."""
    random_action, explored = draw_grasp_exploration(key, n_rotations, height, eps, cfg)
    return jnp.where(explored[:, None], random_action, greedy).astype(jnp.int32), explored


def draw_grasp_exploration(key: jax.Array, n_rotations: int, height: jax.Array, eps, cfg: Exploration):
    """The draws of ``select_grasp`` that need no Q-value, for the same key: which worlds explore
    and their random action.  height: (B, H, W) metres; eps: () or (B,).  Returns ``random_action
    (B, 3) int32 [rotation, row, col]`` and ``explored (B,) bool``; a world that does not explore
    takes its greedy action, so a caller can leave the exploring worlds' Q-values uncomputed."""
    b, h, w = height.shape
    k_explore, k_pixel, k_rot = jax.random.split(key, 3)
    explored = _explore_mask(k_explore, eps, b)
    pix = jax.vmap(lambda k, hm: random_object_cell(k, hm, cfg))(jax.random.split(k_pixel, b), height)
    x_row, x_col = jnp.unravel_index(pix, (h, w))
    x_rot = jax.random.randint(k_rot, (b,), 0, n_rotations)
    return jnp.stack([x_rot, x_row, x_col], axis=-1).astype(jnp.int32), explored


def select_pixel(key: jax.Array, q: jax.Array, height: jax.Array, eps, cfg: Exploration):
    """VANet action selection (no rotation).

    key: PRNG key; q: (B, H, W); height: (B, H, W) metres; eps: () or (B,).
    Returns ``action (B, 2) int32 [row, col]`` and ``explored (B,) bool``.
    """
    b, h, w = q.shape
    k_explore, k_pixel = jax.random.split(key)
    explored = _explore_mask(k_explore, eps, b)
    greedy = jnp.argmax(q.reshape(b, -1), axis=-1).astype(jnp.int32)
    pix = jax.vmap(lambda k, hm: random_object_cell(k, hm, cfg))(jax.random.split(k_pixel, b), height)
    flat = jnp.where(explored, pix, greedy)
    row, col = jnp.unravel_index(flat, (h, w))
    return jnp.stack([row, col], axis=-1).astype(jnp.int32), explored
