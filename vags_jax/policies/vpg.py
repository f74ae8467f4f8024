"""VPG's decision and learning signals, shared by its training stage and the benchmark policy.

Actions are ``(B, 3) int32 [channel, row, col]`` over ``VPGNet``'s ``(B, 2R, H, W)`` Q maps:
channel ``c < R`` pushes along ``c * 2 pi / R`` from the cell, channel ``c >= R`` grasps there
with rotation ``c - R`` (``vags_jax.nets.vpg``).

* ``greedy``: the argmax over both primitives (VPG's test-time rule).
* ``select``: VPG's exploration: with probability epsilon the primitive is drawn at random
  (push or grasp, even odds) and the argmax is taken within its maps; otherwise ``greedy``.
  The pixel is always an argmax (VAGS's DAES explores pixels; VPG does not).
* ``changed_cells`` / ``scene_changed``: VPG's change detection on the height maps before and
  after an action: the cells whose height changed by more than ``vpg.change_min`` and less
  than ``vpg.change_max``, and whether there are more than ``vpg.change_cells`` of them.
* ``reward`` and ``no_future``: VPG's rewards (a successful grasp ``grasp_reward``, a push that
  changed the scene ``push_reward``, else 0) and when its target has no future term (nothing
  changed and no grasp succeeded; or the round ended, as in stage 1).
* ``attempt_of``: an action as the ``Attempt`` the environment executes (``push`` set for pushes).
"""
from __future__ import annotations

from typing import Callable

import jax
import jax.numpy as jnp

from vags_jax import batching
from vags_jax.config import Config, Vpg
from vags_jax.env import Attempt, EnvState, VagsEnv
from vags_jax.env.push import push_pose
from vags_jax.nets.vpg import make_vpg_net


def _argmax(q: jax.Array) -> jax.Array:
    """(B, C, H, W) -> (B, 3) int32 [channel, row, col] of each world's largest value."""
    b, c, h, w = q.shape
    flat = jnp.argmax(q.reshape(b, -1), axis=1)
    return jnp.stack(jnp.unravel_index(flat, (c, h, w)), axis=-1).astype(jnp.int32)


def greedy(q: jax.Array) -> jax.Array:
    """q (B, 2R, H, W) -> action (B, 3) int32: the argmax over both primitives."""
    return _argmax(q)


def select(key: jax.Array, q: jax.Array, eps) -> tuple[jax.Array, jax.Array]:
    """VPG's exploration over q (B, 2R, H, W) with eps () or (B,) -> (action (B, 3) int32,
    explored (B,) bool): an exploring world takes the argmax within a primitive drawn at random."""
    b, c = q.shape[:2]
    R = c // 2
    k_explore, k_prim = jax.random.split(key)
    explored = jax.random.uniform(k_explore, (b,)) < jnp.broadcast_to(jnp.asarray(eps, jnp.float32), (b,))
    grasp = jax.random.bernoulli(k_prim, 0.5, (b,))
    within = _argmax(jnp.where(grasp[:, None, None, None], q[:, R:], q[:, :R]))
    within = within.at[:, 0].add(jnp.where(grasp, R, 0))
    return jnp.where(explored[:, None], within, greedy(q)), explored


def changed_cells(before: jax.Array, after: jax.Array, cfg: Vpg) -> jax.Array:
    """(B, H, W) height maps (m) before and after -> (B,) int32 cells whose height changed by
    more than ``cfg.change_min`` and less than ``cfg.change_max``."""
    d = jnp.abs(after.astype(jnp.float32) - before.astype(jnp.float32))
    return ((d > cfg.change_min) & (d < cfg.change_max)).sum(axis=(1, 2)).astype(jnp.int32)


def scene_changed(before: jax.Array, after: jax.Array, cfg: Vpg) -> jax.Array:
    """(B,) bool: more than ``cfg.change_cells`` cells changed (``changed_cells``)."""
    return changed_cells(before, after, cfg) > cfg.change_cells


def reward(push: jax.Array, success: jax.Array, changed: jax.Array, cfg: Vpg) -> jax.Array:
    """(B,) float32 VPG reward: a push that changed the scene ``push_reward``; a successful grasp
    ``grasp_reward``; anything else 0.  push, success, changed: (B,) bool."""
    r_push = jnp.where(changed, cfg.push_reward, 0.0)
    r_grasp = jnp.where(success, cfg.grasp_reward, 0.0)
    return jnp.where(push, r_push, r_grasp).astype(jnp.float32)


def no_future(success: jax.Array, changed: jax.Array, over: jax.Array) -> jax.Array:
    """(B,) bool: the target is the reward alone -- nothing changed and no grasp succeeded
    (VPG), or the round is over (its next view is another scene)."""
    return over | ~(changed | success)


def attempt_of(env: VagsEnv, state: EnvState, action: jax.Array) -> Attempt:
    """action (B, 3) [channel, row, col] -> the Attempt (direct, 1 motion; ``push`` set where
    channel < R)."""
    R = env.cfg.grasp.n_rotations
    pixel, channel = action[:, 1:], action[:, 0]
    push = channel < R
    g_pos, g_yaw = env.grasp_pose(state, pixel, channel % R)
    p_pos, p_angle = push_pose(env.cfg, state.height, pixel, channel % R)
    position = jnp.where(push[:, None], p_pos, g_pos)
    return env.direct_attempt(position, jnp.where(push, p_angle, g_yaw)).replace(push=push)


def vpg_plan(cfg: Config) -> Callable:
    """The benchmark's ``vpg`` planner: params = VPGNet's ``{"params", "batch_stats"}``; the
    greedy action over both primitives; ``score`` = its Q value."""
    net = make_vpg_net(cfg.net)

    def plan(params, key, env: VagsEnv, state: EnvState) -> Attempt:
        del key
        # (B, 2R, H, W), in world groups of net.forward_batch (inference memory)
        q = batching.map_in_groups(lambda c, h: net.apply(params, c, h, False), (state.color, state.height),
                                   cfg.net.forward_batch)
        action = greedy(q)
        score = q.reshape(q.shape[0], -1).max(axis=1)
        return attempt_of(env, state, action).replace(score=score)

    return plan


__all__ = ["greedy", "select", "changed_cells", "scene_changed", "reward", "no_future", "attempt_of", "vpg_plan"]
