"""VPG's push primitive: batched MJX physics over the simulator's model and state.

``push_batched(sim, state, position, angle, start) -> (SimState, PushResult)`` pushes in every
world at once (pure, jittable; the caller jits it, e.g. inside ``VagsEnv``'s steps):

0. the gripper is placed at rest, fingers closed (pads touching), its TCP (the fingertips'
   midpoint) above ``position`` at the guarded start of ``Simulator.descent_start`` (the
   grasp's ``descent_clearance`` above the highest object within reach), with the closing
   axis along the push so the pads' 24 mm wide outer face leads;
1. ``push.t_settle`` at rest; 2. ``push.t_descend`` down to ``position`` (z clamped to at
   least ``grasp.min_height_above_table`` above the table); 3. ``push.t_push`` straight along
   ``(cos angle, sin angle)`` for ``push.length`` metres; 4. ``push.t_lift`` up by
   ``push.lift_height``; then the gripper is parked and the scene settles for ``grasp.t_post``.

Objects that leave the workspace square (pushed off the table) are deactivated and parked by
the simulator's housekeeping, as after a grasp: the benchmark counts them as lost.  The
servo targets, stepping, pinning of parked bodies, overflow flags and housekeeping are the
simulator's own (``Simulator._run``, ``_housekeep``); this module only adds the push's
schedule.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from vags_jax.sim.scene import FINGER_CLOSED_TARGET
from vags_jax.sim.simulator import SimState, Simulator, _smooth_ramp


@struct.dataclass
class PushResult:
    """Commanded travel (m) of one push per world, all (B,) except ``end`` (B, 3).

    approach: from ``start`` to ``grasp.approach_height`` above the push's start point;
    descend: that height; push: ``push.length``; lift: ``push.lift_height``; end: the TCP's
    position after the lift (where the return to the capture pose starts).
    """

    approach: jax.Array
    descend: jax.Array
    push: jax.Array
    lift: jax.Array
    end: jax.Array


def push_schedule(sim: Simulator) -> np.ndarray:
    """(T, 3) float32 per-step fractions (descend, along, lift) of the push: TCP z =
    z_start + (z_push - z_start) * descend + lift_height * lift, xy = start xy + along *
    length * direction."""
    p, dt = sim.cfg.push, sim.cfg.sim.timestep
    n_settle, n_desc, n_push, n_lift = (max(1, int(round(t / dt))) for t in
                                        (p.t_settle, p.t_descend, p.t_push, p.t_lift))
    zeros, ones = np.zeros, np.ones
    descend = np.concatenate([zeros(n_settle), _smooth_ramp(n_desc, 0.75), ones(n_push + n_lift)])
    along = np.concatenate([zeros(n_settle + n_desc), _smooth_ramp(n_push, 1.0), ones(n_lift)])
    lift = np.concatenate([zeros(n_settle + n_desc + n_push), _smooth_ramp(n_lift, 1.0)])
    return np.stack([descend, along, lift], axis=1).astype(np.float32)


def push_batched(sim: Simulator, state: SimState, position, angle, start):
    """Push in every world: position (B, 3) world point of the fingertips at the push's start,
    angle (B,) push direction (rad, in the world xy-plane), start (B, 3) hand position before
    the push (for ``approach``).  -> (SimState, PushResult)."""
    cfg, p = sim.cfg, sim.cfg.push
    B = state.n_worlds
    tz = cfg.workspace.table_z
    x, y = position[:, 0], position[:, 1]
    zp = jnp.maximum(position[:, 2], tz + cfg.grasp.min_height_above_table)
    d = state.data
    if cfg.grasp.descent_clearance is None:
        zs = zp + cfg.grasp.approach_height
    else:
        zs = sim.descent_start(d, state.active, x, y, zp, state.obj_size)
    yaw_q = jnp.mod(angle + jnp.pi / 2, jnp.pi) - jnp.pi / 2  # the gripper's yaw joint range
    dx, dy = jnp.cos(angle), jnp.sin(angle)
    closed = jnp.zeros((B,))
    qpos = d.qpos.at[:, sim._g_q].set(jnp.stack([x, y, zs, yaw_q, closed, closed], axis=1))  # noqa: SLF001
    d = d.replace(qpos=qpos, qvel=d.qvel.at[:, sim._g_v].set(0.0))  # noqa: SLF001

    def ctrl_fn(s):  # s = (descend, along, lift) fractions
        cols = jnp.stack([x + dx * p.length * s[1], y + dy * p.length * s[1],
                          zs + (zp - zs) * s[0] + p.lift_height * s[2], yaw_q,
                          jnp.full((B,), FINGER_CLOSED_TARGET)], axis=1)
        return jnp.zeros((B, sim.nu)).at[:, sim._g_act].set(cols)  # noqa: SLF001

    d, active, ovf = sim._run(d, state.active, state.overflow, ctrl_fn,  # noqa: SLF001
                              jnp.asarray(push_schedule(sim)), state.obj_size)
    # The gripper goes back to its park pose; what it disturbed settles.
    g_park = jnp.asarray(sim.scene.gripper_park_qpos)
    d = d.replace(qpos=d.qpos.at[:, sim._g_q].set(g_park), qvel=d.qvel.at[:, sim._g_v].set(0.0))  # noqa: SLF001
    park = sim._park_ctrl(B)  # noqa: SLF001
    d, active, ovf = sim._run(d, active, ovf, lambda _: park, jnp.zeros((sim.n_post,)), state.obj_size)  # noqa: SLF001
    state = sim._housekeep(state.replace(data=d, active=active, overflow=ovf))  # noqa: SLF001

    pre = jnp.stack([x, y, zp + cfg.grasp.approach_height], axis=1)
    end = jnp.stack([x + dx * p.length, y + dy * p.length, zp + p.lift_height], axis=1)
    full = lambda v: jnp.full((B,), v, jnp.float32)  # noqa: E731
    result = PushResult(approach=jnp.linalg.norm(pre - start, axis=1), descend=full(cfg.grasp.approach_height),
                        push=full(p.length), lift=full(p.lift_height), end=end)
    return state, result


__all__ = ["PushResult", "push_batched", "push_schedule"]
