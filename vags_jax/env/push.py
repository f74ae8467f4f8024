"""Environment steps with VPG's pushes: a push in heightmap coordinates, and one step where each
world pushes, grasps or (training) starts a new round.

A push is planned as an ``Attempt`` with ``push`` set: ``position`` is where the fingertips start
(the cell's centre, ``push.clearance`` above the surface height there), ``yaw`` the push
direction (rad; rotation index r -> ``r * 2 pi / n_rotations``, so all 16 differ).  It is one
motion and no grasp: ``EnvState.motions`` + 1 and its travel (approach, descent, the push, the
lift) added to ``EnvState.travel``; ``attempts`` and ``successes`` (grasps) are unchanged.
The physics is ``vags_jax.sim.push``.
"""
from __future__ import annotations

import math
from typing import Optional

import jax
import jax.numpy as jnp

from vags_jax.config import Config
from vags_jax.env.environment import Attempt, EnvState, VagsEnv, where_worlds
from vags_jax.perception import camera
from vags_jax.sim.push import PushResult, push_batched
from vags_jax.sim.simulator import GraspResult


def push_pose(cfg: Config, height: jax.Array, pixel: jax.Array, rotation: jax.Array):
    """Heightmap push -> (position (B, 3), angle (B,)): pixel (B, 2) [row, col] of the height
    maps (B, H, W), rotation (B,) index.  x, y: the cell centre; z: ``push.clearance`` above
    the surface height there; angle ``rotation * 2 pi / n_rotations``."""
    xy = camera.pixel_to_world_xy(pixel, cfg.workspace)
    surface = height[jnp.arange(height.shape[0]), pixel[:, 0], pixel[:, 1]]
    z = cfg.workspace.table_z + surface + cfg.push.clearance
    angle = rotation.astype(jnp.float32) * (2 * math.pi / cfg.grasp.n_rotations)
    return jnp.concatenate([xy, z[:, None]], axis=1), angle


def step_push(env: VagsEnv, state: EnvState, attempt: Attempt):
    """Every world pushes as ``attempt`` says (its ``push`` flag is not read) -> (EnvState with
    the new physics, motions + 1 and the push's travel; PushResult).  Not re-observed."""
    sim_state, res = push_batched(env.sim, state.sim, attempt.position, attempt.yaw, attempt.start)
    travel = res.approach + res.descend + res.push + res.lift + attempt.view_travel
    return state.replace(sim=sim_state, motions=state.motions + attempt.motions,
                         travel=state.travel + travel), res


def _no_push(state: EnvState, attempt: Attempt):
    """``step_push``'s output shape when no world pushes: the state unchanged."""
    B = state.n_worlds
    zero = jnp.zeros((B,), jnp.float32)
    return state, PushResult(approach=zero, descend=zero, push=zero, lift=zero, end=attempt.position)


# step_with_pushes: the grasp loop and the push loop both run when the batch mixes them
# (lax.cond skips the push loop when no world pushes); each world keeps its own primitive's.
def step_with_pushes(env: VagsEnv, state: EnvState, attempt: Attempt, key: Optional[jax.Array] = None,
                     observe: bool = True, reset=None):
    """One step where worlds with ``attempt.push`` (B,) push and the others grasp (``attempt``
    as ``VagsEnv.step_attempt``); with ``reset = (mask (B,), reset_key (2,), n_objects (B,))``
    the masked worlds start a new round instead (``VagsEnv.step_attempt_or_reset``) and neither
    push nor grasp.  Then (``observe``) the new global view.
    -> (EnvState, GraspResult: no success where a world pushed, PushResult: zeros where not)."""
    push = attempt.push if reset is None else attempt.push & ~reset[0]
    if reset is None:
        s_g, res_g = env.step_attempt(state, attempt, observe=False)
    else:
        s_g, res_g = env.step_attempt_or_reset(state, attempt, *reset, observe=False)
    s_p, res_p = jax.lax.cond(push.any(), lambda s: step_push(env, s, attempt), lambda s: _no_push(s, attempt),
                              state)
    state = where_worlds(push, s_p, s_g)
    if observe:
        state = env.with_observation(state, key)
    res_g = jax.tree.map(lambda g: jnp.where(push, jnp.zeros_like(g), g), res_g)
    res_g = res_g.replace(object=jnp.where(push, -1, res_g.object))
    res_p = jax.tree.map(lambda v: jnp.where(push.reshape((-1,) + (1,) * (v.ndim - 1)), v, jnp.zeros_like(v)), res_p)
    return state, res_g, res_p


__all__ = ["push_pose", "step_push", "step_with_pushes", "PushResult", "GraspResult"]
