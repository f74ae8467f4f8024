"""Stepping B worlds: fresh data, kinematics, pinning parked bodies, the physics loop and the
housekeeping after it (the ``Simulator``'s ``Stepping`` part)."""
from __future__ import annotations

from typing import Optional

import jax
import jax.numpy as jnp
import mujoco
from mujoco import mjx

from vags_jax.sim.state import Drops, SimState

# Thresholds for housekeeping.
BELOW_TABLE = 0.02  # m; an object whose centre is this far below the table top fell through

# MuJoCo's "fully awake" value of a tree's sleep counter (tree_asleep < 0: awake; >= 0: asleep).
TREE_AWAKE = -(1 + mujoco.mjMINAWAKE)



class Stepping:
    """Physics loop of a ``Simulator`` (uses its ``cfg``, ``mx``, index tables and the other parts)."""

    def _fresh_data(self, qpos, qvel, ctrl) -> mjx.Data:
        """New batched Data from qpos (B, nq), qvel (B, nv), ctrl (B, nu), poses evaluated."""
        d0 = self._template(qpos.shape[0])

        def one(q, v, c):
            return mjx.kinematics(self.mx, d0.replace(qpos=q, qvel=v, ctrl=c))

        return jax.vmap(one)(qpos, qvel, ctrl)

    def _kinematics(self, d: mjx.Data) -> mjx.Data:
        """Body / geom poses (xpos, geom_xpos, geom_xmat, ...) from qpos, for the renderer.

        Cheap (no collision or solver) so that teleports are visible at once; velocities and
        forces are recomputed by the next step anyway.
        """
        return jax.vmap(mjx.kinematics, in_axes=(None, 0))(self.mx, d)

    def _pin_masks(self, active):
        """active (B, P) -> (pin_q (B, nq), pin_v (B, nv)) bool: coordinates of parked bodies."""
        B = active.shape[0]
        parked = ~active
        pin_q = jnp.zeros((B, self.nq), bool).at[:, self._obj_qidx].set(
            jnp.broadcast_to(parked[..., None], (B, self.P, 7)))
        pin_v = jnp.zeros((B, self.nv), bool).at[:, self._obj_vidx].set(
            jnp.broadcast_to(parked[..., None], (B, self.P, 6)))
        return pin_q, pin_v

    def _pin(self, d: mjx.Data, pin_q, pin_v) -> mjx.Data:
        return d.replace(
            qpos=jnp.where(pin_q, self._qpos0, d.qpos),
            qvel=jnp.where(pin_v, 0.0, d.qvel),
        )

    def _wake(self, d: mjx.Data, worlds) -> mjx.Data:
        """Wake every body tree of the worlds where worlds (B,) bool is set (sim.sleep).

        Needed after teleporting objects: a sleeping tree moved by writing qpos would stay
        asleep where it was put (contacts between sleeping trees are not computed), and a tree
        left resting on one that was moved away would float.
        """
        if not self.cfg.sim.sleep:
            return d
        imp = d._impl  # noqa: SLF001
        asleep = jnp.where(worlds[:, None], TREE_AWAKE, imp.tree_asleep)
        return d.replace(_impl=imp.replace(tree_asleep=asleep.astype(imp.tree_asleep.dtype)))

    def _place(self, d: mjx.Data, active, woken) -> mjx.Data:
        """After object qpos were written: wake the worlds where woken (B,) bool is set,
        pin the parked bodies (~active (B, P)) and evaluate the poses for the renderer."""
        pin_q, pin_v = self._pin_masks(active)
        return self._kinematics(self._pin(self._wake(d, woken), pin_q, pin_v))

    def _run(self, d: mjx.Data, active, overflow, ctrl_fn, xs, obj_size, drops: Optional[Drops] = None):
        """Step all worlds once per element of xs (leading dim T); ctrl_fn(x) -> (B, nu).

        Parked bodies (~active) are pinned after every step; obj_size (B, P, 3) gives each
        world's object sizes; ``drops`` (pile scenes) are dropped at their release steps.
        Returns (data, active (B, P), overflow (B,)).
        """
        B = active.shape[0]
        step = self._stepper(obj_size)
        if drops is None:
            pin_q, pin_v = self._pin_masks(active)

            def body(carry, x):
                d, ovf = carry
                d = step(d.replace(ctrl=ctrl_fn(x)))
                d = self._pin(d, pin_q, pin_v)
                return (d, ovf | self._overflow_now(d, B)), None

            (d, overflow), _ = jax.lax.scan(body, (self._pin(d, pin_q, pin_v), overflow), xs)
            return d, active, overflow

        bounds = self.object_bounds(obj_size)  # the sizes do not change during the loop

        def body_drops(carry, x):
            d, active, ovf, t = carry
            d, active = self._drop_due(d, active, t, drops, bounds)
            d = step(d.replace(ctrl=ctrl_fn(x)))
            d = self._pin(d, *self._pin_masks(active))
            return (d, active, ovf | self._overflow_now(d, B), t + 1), None

        (d, active, overflow, _), _ = jax.lax.scan(body_drops, (d, active, overflow, jnp.int32(0)), xs)
        return d, active, overflow

    def _park_ctrl(self, B: int):
        return jnp.broadcast_to(jnp.asarray(self._ctrl_park), (B, self.nu))

    def _housekeep(self, state: SimState) -> SimState:
        """Deactivate + park objects outside the workspace, flag NaNs / tunnelling, poses."""
        d = state.data
        pos = d.qpos[:, self._obj_qidx[:, :3]]  # (B, P, 3)
        xmin, xmax, ymin, ymax = self.cfg.workspace.bounds
        tz = self.cfg.workspace.table_z
        inside = (pos[..., 0] >= xmin) & (pos[..., 0] <= xmax) & (pos[..., 1] >= ymin) & (pos[..., 1] <= ymax)
        below = pos[..., 2] < tz - BELOW_TABLE
        finite = jnp.isfinite(d.qpos).all(axis=1) & jnp.isfinite(d.qvel).all(axis=1)
        error = state.error | ~finite | (state.active & below).any(axis=1)
        active = state.active & inside & ~below
        d = self._place(d, active, (active != state.active).any(axis=1))
        return state.replace(data=d, active=active, error=error)
