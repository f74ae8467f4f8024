"""The top-down grasp primitive over B worlds, optionally with new scenes settling in the same
physics loop (the ``Simulator``'s ``GraspPrimitive`` part)."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from mujoco import mjx

from vags_jax.sim.scene import FINGER_CLOSED_TARGET
from vags_jax.sim.state import GraspResult, SimState

# Guarded descent: an object counts as "within reach" of the descending gripper when its
# bounding sphere comes closer than finger_stroke / 2 + REACH_MARGIN to the grasp axis (the open
# pads reach finger_stroke / 2 + 8 mm along the closing axis and 12 mm across it; the palm is
# narrower).
REACH_MARGIN = 0.02



def _smooth_ramp(n: int, frac: float) -> np.ndarray:
    """(n,) goes 0 -> 1 along a half cosine over the first ``frac * n`` steps, then holds 1."""
    k = max(1, int(round(frac * n)))
    u = np.clip(np.arange(1, n + 1) / k, 0.0, 1.0)
    return 0.5 - 0.5 * np.cos(np.pi * u)



class GraspPrimitive:
    """The grasp of a ``Simulator`` (uses its ``cfg``, ``scene``, schedule and the other parts)."""

    # Long (one reason): one physics loop (lax.scan) with the closures its steps share.
    def _grasp_impl(self, state: SimState, position, yaw, start, reset=None):
        """Grasp in every world; with ``reset = (mask (B,), keys (B, 2), n_objects (B,))`` the
        masked worlds instead get a new scene dropped and settling in the same physics loop.

        Grasp (all worlds, one jitted call; durations from ``cfg.grasp``):
        0. the gripper is placed (teleported, at rest) with its TCP ``approach_height`` above the
           grasp point, closing axis at ``yaw``, fingers open.  The grasp point is ``position`` with
           z clamped to ``>= table_z + min_height_above_table``.  TCP = midpoint of the fingertips.
           With ``cfg.grasp.descent_clearance`` = c (guarded descent) it is placed lower, at
           ``descent_start``: c above the highest point (top of the world-frame bounding box) of any
           active object whose bounding sphere comes within the gripper's reach of the grasp axis, or
           c above the grasp point if that is higher, capped at ``approach_height`` -- the free-space
           part of the descent, where nothing can be touched, is not simulated.
        1. open / settle ``t_settle``;  2. descend to the grasp point ``t_descend`` (smooth profile
           over the first 75 %, then hold);  3. close ``t_close``;  4. lift by ``lift_height``
           ``t_lift`` (smooth over the first ``1 - lift_hold`` of it, then hold).
        Then success is evaluated: an active object rose by more than ``success_lift`` and is above
        ``table_z + success_lift`` and the pad gap is > ``closed_gap``.  The grasped object is the
        lifted one nearest to the TCP; it is parked (active False).  The gripper is parked and the
        scene settles for another ``t_post`` so dropped / disturbed objects come to rest before
        the next observation.
        ``grasp_or_reset_batched`` is the same loop where some worlds, instead of grasping, get a
        new scene (drawn as by ``reset``) that settles while the others grasp; the loop then lasts
        max(grasp, ``settle_time``) so every new scene gets its full settle time.  Objects that left the workspace square (or fell through the table)
        are deactivated and parked too, after every reset and grasp.
        Motion distances (commanded, metres, for a picks-per-hour model): ``approach`` = straight
        line from ``start`` (default: ``cfg.camera.global_position``, where the eye-in-hand robot
        captured the global view) to the pre-grasp pose; ``descend`` = pre-grasp to grasp point
        (= approach_height); ``lift`` = lift_height.  Returning / placing is left to the model."""
        cfg, g = self.cfg, self.cfg.grasp
        B, P = state.n_worlds, self.P
        tz = cfg.workspace.table_z
        x, y = position[:, 0], position[:, 1]
        zg = jnp.maximum(position[:, 2], tz + g.min_height_above_table)
        zpre = zg + g.approach_height
        yaw_q = jnp.mod(yaw + jnp.pi / 2, jnp.pi) - jnp.pi / 2
        d = state.data
        g_park = jnp.asarray(self.scene.gripper_park_qpos)
        fo = jnp.full((B,), self.finger_open)
        # Where the simulated descent starts (the free-space part above it is skipped).
        zs = zpre if g.descent_clearance is None else self.descent_start(d, state.active, x, y, zg, state.obj_size)
        pre_grasp = jnp.stack([x, y, zs, yaw_q, fo, fo], axis=1)
        drops = None
        if reset is None:
            grasping = jnp.ones((B,), bool)
            gripper_q = pre_grasp
        else:
            mask, keys, n_new = reset
            grasping = ~mask
            state, drops = self._start_rounds(state, mask, keys, n_new)
            drop_bounds = self.object_bounds(state.obj_size) if drops is not None else None
            d = state.data
            gripper_q = jnp.where(mask[:, None], g_park, pre_grasp)
        z_before = d.qpos[:, self._obj_qidx[:, 2]]  # (B, P)
        qpos = d.qpos.at[:, self._g_q].set(gripper_q)
        qvel = d.qvel.at[:, self._g_v].set(0.0)
        d = d.replace(qpos=qpos, qvel=qvel)
        park_ctrl = self._park_ctrl(B)
        n_main = self.schedule.shape[0]

        def ctrl_fn(s):  # s = (descend, lift, close) fractions
            z = zs + (zg - zs) * s[0] + g.lift_height * s[1]
            f = self.finger_open + (FINGER_CLOSED_TARGET - self.finger_open) * s[2]
            cols = jnp.stack([x, y, z, yaw_q, jnp.full((B,), f)], axis=1)
            ctrl = jnp.zeros((B, self.nu)).at[:, self._g_act].set(cols)
            return jnp.where(grasping[:, None], ctrl, park_ctrl)

        def evaluate(d, active):
            """After the lift: success (B,), object (B,), gap (B,), active without the grasped."""
            pos = d.qpos[:, self._obj_qidx[:, :3]]  # (B, P, 3)
            rise = pos[..., 2] - z_before
            lifted = active & (rise > g.success_lift) & (pos[..., 2] > tz + g.success_lift)
            gap = d.qpos[:, self._g_q[4]] + d.qpos[:, self._g_q[5]]
            tcp = d.qpos[:, self._g_q[:3]]
            dist = jnp.where(lifted, jnp.linalg.norm(pos - tcp[:, None], axis=-1), jnp.inf)
            idx = jnp.argmin(dist, axis=1).astype(jnp.int32)
            success = grasping & lifted.any(axis=1) & (gap > g.closed_gap)
            grasped = success[:, None] & (jnp.arange(P)[None] == idx[:, None])
            return success, jnp.where(success, idx, -1), jnp.where(grasping, gap, 0.0), active & ~grasped

        step = self._stepper(state.obj_size)
        n_total = self.n_grasp_steps if reset is None else max(self.n_grasp_steps, self.n_settle_reset)
        sched = np.concatenate([self.schedule, np.zeros((n_total - n_main, 3), np.float32)])
        xs = (jnp.arange(n_total), jnp.asarray(sched))
        res0 = (jnp.zeros((B,), bool), jnp.full((B,), -1, jnp.int32), jnp.zeros((B,)))

        def body(carry, x):
            d, active, ovf, res = carry
            t, s = x
            if drops is not None:  # new pile scenes: their objects drop one after another
                d, active = self._drop_due(d, active, t, drops, drop_bounds)
            # At the first post-lift step: judge the grasp, park the gripper and the object.
            is_eval = t == n_main
            ev = evaluate(d, active)
            res = jax.tree.map(lambda new, old: jnp.where(is_eval, new, old), ev[:3], res)
            active = jnp.where(is_eval, ev[3], active)
            d = d.replace(
                qpos=jnp.where(is_eval, d.qpos.at[:, self._g_q].set(g_park), d.qpos),
                qvel=jnp.where(is_eval, d.qvel.at[:, self._g_v].set(0.0), d.qvel),
            )
            ctrl = jnp.where(t >= n_main, park_ctrl, ctrl_fn(s))
            pin_q, pin_v = self._pin_masks(active)
            d = self._pin(step(d.replace(ctrl=ctrl)), pin_q, pin_v)
            return (d, active, ovf | self._overflow_now(d, B), res), None

        carry = (d, state.active, state.overflow, res0)
        (d, active, ovf, (success, obj, gap)), _ = jax.lax.scan(body, carry, xs)
        state = self._housekeep(state.replace(data=d, active=active, overflow=ovf))

        pre = jnp.stack([x, y, zpre], axis=1)
        zero = jnp.zeros((B,), jnp.float32)
        result = GraspResult(
            success=success,
            object=obj,
            gripper_gap=gap,
            approach=jnp.where(grasping, jnp.linalg.norm(pre - start, axis=1), zero),
            descend=jnp.where(grasping, zpre - zg, zero),
            lift=jnp.where(grasping, g.lift_height, zero),
        )
        return state, result

    def descent_start(self, d: mjx.Data, active, x, y, zg, obj_size=None):
        """(B,) TCP height where a guarded descent starts (``cfg.grasp.descent_clearance``).

        d: batched Data with current geom poses; active: (B, P) bool; x, y, zg: (B,) grasp
        point; obj_size: (B, P, 3) per-world object sizes (None: the compiled sizes).  The top of an object is the highest corner of its geom's bounding box in the
        world frame; objects count when their bounding sphere (xy distance) comes within
        ``finger_stroke / 2 + REACH_MARGIN`` of the grasp axis.  Result: clearance above the
        highest such top or above zg, whichever is higher, capped at ``zg + approach_height``.
        """
        g = self.cfg.grasp
        ids = self.scene.object_geom_ids
        pos, rot = d.geom_xpos[:, ids], d.geom_xmat[:, ids]  # (B, P, 3), (B, P, 3, 3)
        rz = rot[:, :, 2, :]  # (B, P, 3): world z of each geom axis
        if obj_size is None:
            aabb, rbound = jnp.asarray(self._obj_aabb), jnp.asarray(self._obj_rbound)
        else:
            aabb, rbound = self.object_bounds(obj_size)
        c, h = aabb[..., :3], aabb[..., 3:]
        top = pos[..., 2] + (rz * c).sum(-1) + (jnp.abs(rz) * h).sum(-1)  # (B, P)
        dxy = jnp.linalg.norm(pos[..., :2] - jnp.stack([x, y], axis=-1)[:, None], axis=-1)
        near = active & (dxy < g.finger_stroke / 2 + REACH_MARGIN + rbound)
        z_top = jnp.where(near, top, -jnp.inf).max(axis=1)
        return jnp.minimum(zg + g.approach_height, jnp.maximum(zg, z_top) + g.descent_clearance)

    def grasp_at(self, state: SimState, position, yaw, start=None):
        """Top-down grasp in every world.

        position: (B, 3) world grasp point (TCP = fingertip midpoint); yaw: (B,) closing-axis
        angle (rad); start: optional (B, 3) hand position before the grasp (for ``approach``).
        Returns (SimState, GraspResult).
        """
        B = state.n_worlds
        position = jnp.asarray(position, jnp.float32)
        yaw = jnp.asarray(yaw, jnp.float32)
        if position.shape != (B, 3) or yaw.shape != (B,):
            raise ValueError(
                f"grasp_at: expected position (B, 3) and yaw (B,) with B = {B} worlds; got "
                f"{position.shape} and {yaw.shape}"
            )
        if start is None:
            start = jnp.broadcast_to(jnp.asarray(self.cfg.camera.global_position, jnp.float32), (B, 3))
        return self._grasp_jit(state, position, yaw, jnp.asarray(start, jnp.float32))

    def grasp_batched(self, state: SimState, position, yaw, start):
        return self._grasp_jit(state, position, yaw, start)

    # grasp_or_reset_batched(state, position, yaw, start, reset (B,) bool, keys (B, 2),
    # n_objects (B,) int32) -> (SimState, GraspResult): the worlds with ``reset`` set do not
    # grasp; they get a new scene (as ``reset``), which settles during the same physics loop
    # (max(grasp, settle_time) long), and their GraspResult is a failure with zero travel.
    def grasp_or_reset_batched(self, state: SimState, position, yaw, start, reset, keys, n_objects):
        return self._grasp_reset_jit(state, position, yaw, start, reset, keys, n_objects)

    def _grasp_or_reset_impl(self, state, position, yaw, start, reset, keys, n_objects):
        return self._grasp_impl(state, position, yaw, start, (reset, keys, n_objects))
