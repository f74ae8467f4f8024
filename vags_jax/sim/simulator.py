"""Batched MJX physics: scene reset (drop + settle) and the top-down grasp primitive.

``Simulator(cfg, scene)`` is built once.  It holds the ``mjx.Model`` for ``cfg.sim.impl``
("jax": pure JAX, any device; "warp": MJX's MuJoCo Warp backend, NVIDIA GPUs, needs
warp-lang) and jitted, batched functions over ``SimState`` (leading dim B = worlds):

* ``reset(key, n_objects) -> SimState``: per world draw ``n_objects`` pool bodies at random
  (random shapes), random palette colours (distinct within a world for up to 10 objects),
  drop them at random x, y in the workspace shrunk by ``cfg.scene.drop_margin``, random
  orientation, centre at ``cfg.scene.drop_height`` above the table; bodies whose bounding
  spheres would overlap another earlier-drawn body's in xy are stacked above it (spawn never
  interpenetrates), then ``cfg.scene.settle_time`` seconds of physics.  The rest is parked.
* ``grasp_at(state, position, yaw) -> (SimState, GraspResult)``: one top-down grasp in every
  world at once (see "Grasp" below); ``grasp_or_reset_batched``: the same, where the masked
  worlds start a new scene instead (the training loop's step).
* helpers: ``empty`` (all parked, for scripted scenes), ``set_objects``, ``object_poses``,
  ``object_velocities``, ``object_positions``, ``park_objects``, ``settle``, ``take_worlds``; host-side
  ``check_overflow(state)``.  Pure-jit users may call them inside their own jit.

Parking (details in ``vags_jax.sim.scene``): unused / grasped objects are pinned at fixed poses
far outside the workspace (their qpos is reset and velocity zeroed after every step, so they
never move and never touch anything); the gripper is teleported to a park pose 2 m beside the
workspace between grasps.

Yaw convention: ``yaw`` is the angle of the CLOSING axis in the world xy-plane (fingers move
along (cos yaw, sin yaw)); yaw and yaw + pi are the same grasp (wrapped to [-pi/2, pi/2)).

Grasp phases, success and travel: ``_grasp_impl``.  Contact and constraint buffers, overflow
and physics failures (never silently accepted: ``SimState.overflow`` / ``error``, and the
host-side ``check_overflow``): ``Simulator._overflow_now``.

The class is assembled from parts, one module each: ``state`` (SimState, GraspResult, Drops,
check_overflow), ``buffers`` (contact / constraint buffers, overflow), ``world_model``
(per-world sizes and masses), ``stepping`` (the physics loop, pinning, housekeeping), ``piles``
(scene draws and the reset), ``grasp`` (the grasp primitive); this module holds the
constructor, object queries and scripted-scene helpers.
"""
from __future__ import annotations

import warnings

import jax
import jax.numpy as jnp
import numpy as np
from mujoco import mjx

from vags_jax.config import Config
from vags_jax.sim.buffers import BufferSizes
from vags_jax.sim.grasp import GraspPrimitive, _smooth_ramp
from vags_jax.sim.piles import PILE_DROP_SHARE, ScenePiles
from vags_jax.sim.scene import KIND_BOX, KIND_CAPSULE, KIND_FIXED, KIND_SPHERE, SceneModel
from vags_jax.sim.state import Drops, GraspResult, SimState, check_overflow
from vags_jax.sim.stepping import Stepping
from vags_jax.sim.world_model import PerWorldModel

__all__ = ["Drops", "GraspResult", "SimState", "Simulator", "check_overflow"]


# Longest time step whose grasp outcomes were checked under MJX jax (bench/RESULTS.md, "Environment throughput").
JAX_MAX_TIMESTEP = 0.002


def _require_warp() -> None:
    try:
        import warp  # noqa: F401
    except ImportError as e:
        raise ImportError(
            "Config.sim.impl='warp' needs warp-lang (MJX's MuJoCo Warp backend, NVIDIA GPU): "
            "pip install 'vags_jax[warp]', or set Config.sim.impl='jax'"
        ) from e


class Simulator(BufferSizes, PerWorldModel, Stepping, ScenePiles, GraspPrimitive):
    """Batched physics for one scene.  Build once; every public method is jit-compiled."""

    def __init__(self, cfg: Config, scene: SceneModel):
        self.cfg, self.scene = cfg, scene
        m = scene.mj_model
        self.impl = cfg.sim.impl
        if self.impl == "warp":
            _require_warp()
        elif cfg.sim.timestep > JAX_MAX_TIMESTEP:
            warnings.warn(
                f"sim.timestep = {cfg.sim.timestep} s with impl 'jax': MJX jax let the finger pads "
                f"be pried open at 4 ms (wrong-axis cuboid grasps succeeded); use "
                f"sim.timestep={JAX_MAX_TIMESTEP} with impl 'jax' (longer steps were checked "
                "only on impl 'warp')", stacklevel=2)
        self.mx = mjx.put_model(m, impl=self.impl)
        if self.impl == "warp":
            # MuJoCo Warp prints from its kernels on every step that hits a limit; we read the
            # same per-world flags (d._impl.overflow) and report them ourselves instead.
            opt = self.mx.opt
            self.mx = self.mx.replace(opt=opt.replace(_impl=opt._impl.replace(warn_overflow=0)))  # noqa: SLF001
        self.P, self.N = scene.pool_size, cfg.scene.max_objects
        self.nq, self.nv, self.nu = m.nq, m.nv, m.nu
        self._obj_qidx = scene.object_qpos_adr[:, None] + np.arange(7)  # (P, 7)
        self._obj_vidx = scene.object_dof_adr[:, None] + np.arange(6)  # (P, 6)
        self._qpos0 = scene.park_qpos_full  # (nq,) objects and gripper parked
        self._g_q = scene.gripper_qpos_adr
        self._g_v = scene.gripper_dof_adr
        self._g_act = scene.gripper_actuator_ids
        self.finger_open = cfg.grasp.finger_stroke / 2
        ids = scene.object_geom_ids
        self._obj_aabb = np.asarray(m.geom_aabb[ids], np.float32)  # (P, 6) centre, half size (geom frame)
        self._obj_rbound = np.asarray(m.geom_rbound[ids], np.float32)  # (P,)
        self._sized = scene.has_sized_objects
        self._fixed = np.asarray(scene.object_kind == KIND_FIXED)  # (P,)
        self._ctrl_park = scene.park_ctrl  # (nu,)

        dt = cfg.sim.timestep
        g = cfg.grasp
        steps = lambda t: max(1, int(round(t / dt)))  # noqa: E731
        self.n_settle_reset = int(round(cfg.scene.settle_time / dt))
        # "pile": the j-th drawn body drops at step j * this (the last at PILE_DROP_SHARE of the
        # settle), so each lands on what is already there.
        self.pile_release_interval = max(1, int(PILE_DROP_SHARE * self.n_settle_reset) // max(1, cfg.scene.max_objects - 1))
        n_open, n_desc, n_close, n_lift = (steps(t) for t in (g.t_settle, g.t_descend, g.t_close, g.t_lift))
        self.n_post = steps(g.t_post)
        zeros, ones = np.zeros, np.ones
        descend = np.concatenate([zeros(n_open), _smooth_ramp(n_desc, 0.75), ones(n_close + n_lift)])
        lift = np.concatenate([zeros(n_open + n_desc + n_close), _smooth_ramp(n_lift, 1.0 - g.lift_hold)])
        close_ramp = np.clip(np.arange(1, n_close + 1) / max(1, n_close // 3), 0.0, 1.0)
        close = np.concatenate([zeros(n_open + n_desc), close_ramp, ones(n_lift)])
        # (T, 3) per-step fractions (descend, lift, close) of the grasp up to the evaluation:
        # TCP z = zpre + (zg - zpre) * descend + lift_height * lift,
        # finger target = open + (closed - open) * close.
        self.schedule = np.stack([descend, lift, close], axis=1).astype(np.float32)
        self.n_grasp_steps = self.schedule.shape[0] + self.n_post

        self._template_cache: dict[int, mjx.Data] = {}
        self._reset_jit = jax.jit(self._reset_impl)
        self._redrop_jit = jax.jit(self._redrop_impl)
        self._grasp_jit = jax.jit(self._grasp_impl)
        self._grasp_reset_jit = jax.jit(self._grasp_or_reset_impl)
        self._settle_jit = jax.jit(self._settle_impl, static_argnums=1)
        self._set_jit = jax.jit(self._set_objects_impl)
        self._empty_jit = jax.jit(self._empty_impl, static_argnums=0)
        self._park_jit = jax.jit(self._park_objects_impl)
        self._take_jit = jax.jit(self._take_worlds_impl)

    def object_poses(self, state: SimState):
        """-> (pos (B, P, 3), quat (B, P, 4) wxyz) of every pool body (parked ones included)."""
        q = state.data.qpos[:, self._obj_qidx]
        return q[..., :3], q[..., 3:]

    def object_bottoms(self, state: SimState) -> jax.Array:
        """(B, P) height (m) above the table of each body's lowest point: exact for boxes,
        capsules and spheres; for meshes the lowest corner of the geom's world bounding box (a
        few mm low when tilted).  A body whose bottom is clearly above 0 rests on another."""
        ids = self.scene.object_geom_ids
        d = state.data
        pos, rot = d.geom_xpos[:, ids], d.geom_xmat[:, ids]  # (B, P, 3), (B, P, 3, 3)
        rz = rot[:, :, 2, :]  # world z of each geom axis
        aabb, _ = self.object_bounds(state.obj_size)
        c, h = aabb[..., :3], aabb[..., 3:]
        low = pos[..., 2] + (rz * c).sum(-1) - (jnp.abs(rz) * h).sum(-1)
        kind = jnp.asarray(self.scene.object_kind)
        size = state.obj_size
        round_low = pos[..., 2] - size[..., 0] - jnp.where(kind == KIND_CAPSULE, jnp.abs(rz[..., 2]) * size[..., 1], 0.0)
        low = jnp.where((kind == KIND_CAPSULE) | (kind == KIND_SPHERE), round_low, low)
        return low - self.cfg.workspace.table_z

    def piled(self, state: SimState, lift: float = 0.005, tilt_deg: float = 10.0) -> jax.Array:
        """(B, P) bool: active bodies that rest on or lean against another body -- their lowest
        point is more than ``lift`` above the table, or (boxes, capsules) they are tilted by
        more than ``tilt_deg`` from every pose they can rest in alone on a flat table (a box on
        a face: some axis vertical; a capsule on its side: its axis horizontal)."""
        ids = self.scene.object_geom_ids
        rz = state.data.geom_xmat[:, ids][:, :, 2, :]  # (B, P, 3)
        kind = jnp.asarray(self.scene.object_kind)
        s = np.sin(np.radians(tilt_deg))
        box_tilted = jnp.abs(rz).max(-1) < np.cos(np.radians(tilt_deg))
        cap_tilted = jnp.abs(rz[..., 2]) > s
        tilted = jnp.where(kind == KIND_BOX, box_tilted, jnp.where(kind == KIND_CAPSULE, cap_tilted, False))
        return state.active & ((self.object_bottoms(state) > lift) | tilted)

    def object_velocities(self, state: SimState) -> jax.Array:
        """-> (B, P, 6) linear (m/s) then angular (rad/s) velocity of every pool body."""
        return state.data.qvel[:, self._obj_vidx]

    def object_positions(self, state: SimState) -> jax.Array:
        """(B, P, 3) body positions (bounding-box centres)."""
        return state.data.qpos[:, self._obj_qidx[:, :3]]

    def _park_objects_impl(self, state: SimState, mask) -> SimState:
        active = state.active & ~mask
        d = self._place(state.data, active, mask.any(axis=1))
        return state.replace(data=d, active=active)

    def park_objects(self, state: SimState, mask) -> SimState:
        """Remove objects: mask (B, P) bool -> deactivated and parked (poses re-evaluated)."""
        return self._park_jit(state, jnp.asarray(mask, bool))

    def _empty_impl(self, n_worlds: int) -> SimState:
        B = n_worlds
        qpos = jnp.broadcast_to(jnp.asarray(self._qpos0), (B, self.nq))
        d = self._fresh_data(qpos, jnp.zeros((B, self.nv)), self._park_ctrl(B))
        rgb = jnp.broadcast_to(jnp.asarray(self.scene.default_geom_rgb), (B,) + self.scene.default_geom_rgb.shape)
        zeros = jnp.zeros((B,), bool)
        size = jnp.broadcast_to(jnp.asarray(self.scene.object_size), (B, self.P, 3))
        return SimState(data=d, active=jnp.zeros((B, self.P), bool), geom_rgb=rgb,
                        n_objects=jnp.zeros((B,), jnp.int32), error=zeros, overflow=zeros,
                        obj_size=size)

    def empty(self, n_worlds: int) -> SimState:
        """B = n_worlds worlds with every object and the gripper parked (for scripted scenes)."""
        return self._empty_jit(int(n_worlds))

    def _set_objects_impl(self, state, pos, quat, active, size):
        qpos = state.data.qpos.at[:, self._obj_qidx].set(jnp.concatenate([pos, quat], axis=-1))
        qvel = state.data.qvel.at[:, self._obj_vidx].set(0.0)
        d = self._place(state.data.replace(qpos=qpos, qvel=qvel), active, jnp.ones((state.n_worlds,), bool))
        return state.replace(data=d, active=active, n_objects=active.sum(axis=1).astype(jnp.int32),
                             obj_size=size)

    def set_objects(self, state: SimState, pos, quat, active, size=None) -> SimState:
        """Teleport objects (scripted scenes, label generation): pos (B, P, 3), quat (B, P, 4)
        wxyz, active (B, P) bool; inactive ones are parked, velocities zeroed.  size: optional
        (B, P, 3) geom sizes (sized families only; fixed shapes keep theirs), default: unchanged."""
        B = state.n_worlds
        if size is None:
            size = state.obj_size
        else:
            size = jnp.asarray(size, jnp.float32)
            if size.shape != (B, self.P, 3):
                raise ValueError(f"set_objects: size must have shape ({B}, {self.P}, 3), got {size.shape}")
            size = jnp.where(jnp.asarray(self._fixed)[None, :, None], state.obj_size, size)
        return self._set_jit(state, jnp.asarray(pos, jnp.float32), jnp.asarray(quat, jnp.float32),
                             jnp.asarray(active, bool), size)

    def _settle_impl(self, state: SimState, n_steps: int) -> SimState:
        B = state.n_worlds
        park_ctrl = self._park_ctrl(B)
        d, _, ovf = self._run(state.data, state.active, state.overflow, lambda _: park_ctrl, jnp.zeros((n_steps,)),
                              state.obj_size)
        return self._housekeep(state.replace(data=d, overflow=ovf))

    def settle(self, state: SimState, seconds: float) -> SimState:
        """Simulate ``seconds`` with the gripper parked (static duration, compiled per value)."""
        return self._settle_jit(state, int(round(seconds / self.cfg.sim.timestep)))

    def take_worlds(self, state: SimState, idx) -> SimState:
        """Select / repeat worlds: idx (B',) int -> SimState with B' worlds (velocities kept).

        Data is rebuilt from qpos / qvel / ctrl (works for both impls; warm starts are lost).
        """
        return self._take_jit(state, jnp.asarray(idx, jnp.int32))

    def _take_worlds_impl(self, state: SimState, idx) -> SimState:
        d = state.data
        nd = self._fresh_data(d.qpos[idx], d.qvel[idx], d.ctrl[idx])
        return SimState(data=nd, active=state.active[idx], geom_rgb=state.geom_rgb[idx],
                        n_objects=state.n_objects[idx], error=state.error[idx],
                        overflow=state.overflow[idx], obj_size=state.obj_size[idx])

    # Pure, un-validated batched entry points for use inside the caller's own jit:
    # reset_batched(keys (B, 2), n_objects (B,) int32) -> SimState;
    # grasp_batched(state, position (B, 3), yaw (B,), start (B, 3)) -> (SimState, GraspResult).
    def reset_batched(self, keys, n_objects) -> SimState:
        return self._reset_jit(keys, n_objects)


    check_overflow = staticmethod(check_overflow)
