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
"""
from __future__ import annotations

import warnings
from typing import Optional

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct
import mujoco
from mujoco import mjx

from vags_jax.config import Config
from vags_jax.sim.scene import (FINGER_CLOSED_TARGET, KIND_BOX, KIND_CAPSULE, KIND_FIXED, KIND_SPHERE, SceneModel, contacts_per_world, rows_per_contact,
                            sized_body_physics)

# mujoco_warp OverflowType bits that mean a buffer was too small (data were dropped):
# NEFC, NJMAX_NNZ, BROADPHASE, NARROWPHASE, CCD, EPA_HORIZON.  Solver / line-search iteration
# limits (bits 9, 10) are convergence warnings, not dropped data.
WARP_BUFFER_OVERFLOW_BITS = (1 << 0) | (1 << 1) | (1 << 2) | (1 << 3) | (1 << 4) | (1 << 8)

# Thresholds for housekeeping.
BELOW_TABLE = 0.02  # m; an object whose centre is this far below the table top fell through
SPAWN_GAP = 0.005  # m between bounding spheres of stacked spawn poses
# "pile" placement: each body is dropped from this far above what lies under it, tilted up to
# PILE_TILT; the drops are spread over the first PILE_DROP_SHARE of the reset's settle time.
PILE_GAP = 0.02  # m
PILE_DROP_SHARE = 0.5
PILE_TILT = 0.35  # rad (20 deg)
# Guarded descent: an object counts as "within reach" of the descending gripper when its
# bounding sphere comes closer than finger_stroke / 2 + REACH_MARGIN to the grasp axis (the open
# pads reach finger_stroke / 2 + 8 mm along the closing axis and 12 mm across it; the palm is
# narrower).
REACH_MARGIN = 0.02
# Longest time step whose grasp outcomes were checked under MJX jax (see "Time step" above).
JAX_MAX_TIMESTEP = 0.002
# MuJoCo's "fully awake" value of a tree's sleep counter (tree_asleep < 0: awake; >= 0: asleep).
TREE_AWAKE = -(1 + mujoco.mjMINAWAKE)


@struct.dataclass
class SimState:
    """Batched simulator state, B worlds, P pool objects.

    data: mjx.Data with leading dim B (qpos (B, nq), geom_xpos (B, ngeom, 3), ...).
    active: (B, P) bool, object is on the table (drawn at reset, not grasped, not lost).
    geom_rgb: (B, ngeom, 3) uint8 per-world colours for the renderer.
    n_objects: (B,) int32 objects drawn at the last reset.
    error: (B,) bool, physics failure since the last reset (NaN / object through the table).
    overflow: (B,) bool, impl "warp": a contact / constraint buffer was full on some step.
    obj_size: (B, P, 3) float32 MuJoCo geom_size of every pool body in each world (drawn at
      reset for sized families; the compiled size for fixed shapes).
    """

    data: mjx.Data
    active: jax.Array
    geom_rgb: jax.Array
    n_objects: jax.Array
    error: jax.Array
    overflow: jax.Array
    obj_size: jax.Array

    @property
    def n_worlds(self) -> int:
        return self.active.shape[0]


@struct.dataclass
class GraspResult:
    """Outcome of one grasp per world, all (B,).

    success: bool; object: int32 pool index of the grasped object or -1;
    gripper_gap: pad gap after the lift (m); approach, descend, lift: commanded travel (m).
    """

    success: jax.Array
    object: jax.Array
    gripper_gap: jax.Array
    approach: jax.Array
    descend: jax.Array
    lift: jax.Array


@struct.dataclass
class Drops:
    """Objects of new "pile" scenes still to be dropped during the settle that follows, B worlds.

    release: (B, P) int32 physics step (counted from the start of the loop) at which each body
      is dropped, -1 = none (not drawn, already placed, or a world not being reset).
    xy: (B, P, 2) drop position; quat: (B, P, 4) wxyz drop orientation.
    half_z: (B, P) half height of the body's world bounding box in that orientation; radius:
      (B, P) its bounding-sphere radius (which lower bodies it may land on).
    """

    release: jax.Array
    xy: jax.Array
    quat: jax.Array
    half_z: jax.Array
    radius: jax.Array


def check_overflow(state: SimState, warn: bool = False) -> None:
    """Host-side check of ``state.overflow`` and ``state.error``; raise RuntimeError (or warn)."""
    overflow = np.asarray(jax.device_get(state.overflow))
    error = np.asarray(jax.device_get(state.error))
    msgs = []
    if overflow.any():
        msgs.append(
            f"contact/constraint buffer full in {int(overflow.sum())} of {overflow.size} worlds "
            f"(e.g. worlds {np.flatnonzero(overflow)[:8].tolist()}): contacts were dropped and "
            "objects may fall through; raise Config.sim.contacts_per_world (impl 'jax'; "
            "warp: naconmax = B x this) or Config.sim.naconmax (warp, contacts over all "
            "worlds) and/or Config.sim.njmax (warp, constraint rows per world)"
        )
    if error.any():
        msgs.append(
            f"physics failure (NaN or an object through the table) in {int(error.sum())} of "
            f"{error.size} worlds (e.g. worlds {np.flatnonzero(error)[:8].tolist()}): reset those "
            "worlds; if it recurs lower Config.sim.timestep or raise Config.sim.iterations"
        )
    if msgs:
        msg = "vags_jax.sim.simulator: " + "; ".join(msgs)
        if warn:
            warnings.warn(msg, RuntimeWarning, stacklevel=2)
        else:
            raise RuntimeError(msg)


def _require_warp() -> None:
    try:
        import warp  # noqa: F401
    except ImportError as e:
        raise ImportError(
            "Config.sim.impl='warp' needs warp-lang (MJX's MuJoCo Warp backend, NVIDIA GPU): "
            "pip install 'vags_jax[warp]', or set Config.sim.impl='jax'"
        ) from e


def _smooth_ramp(n: int, frac: float) -> np.ndarray:
    """(n,) goes 0 -> 1 along a half cosine over the first ``frac * n`` steps, then holds 1."""
    k = max(1, int(round(frac * n)))
    u = np.clip(np.arange(1, n + 1) / k, 0.0, 1.0)
    return 0.5 - 0.5 * np.cos(np.pi * u)


def _quat_mul(a, b):
    """Hamilton product of (..., 4) wxyz quaternions."""
    aw, ax, ay, az = jnp.moveaxis(a, -1, 0)
    bw, bx, by, bz = jnp.moveaxis(b, -1, 0)
    return jnp.stack([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                      aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw], -1)


def _quat_to_mat(q):
    """(..., 4) unit wxyz quaternions -> (..., 3, 3) rotation matrices."""
    w, x, y, z = jnp.moveaxis(q, -1, 0)
    return jnp.stack([
        jnp.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        jnp.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        jnp.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], -2)


def _is_traced(x) -> bool:
    return isinstance(x, jax.core.Tracer)


class Simulator:
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
        self._grasp_jit = jax.jit(self._grasp_impl)
        self._grasp_reset_jit = jax.jit(self._grasp_or_reset_impl)
        self._settle_jit = jax.jit(self._settle_impl, static_argnums=1)
        self._set_jit = jax.jit(self._set_objects_impl)
        self._empty_jit = jax.jit(self._empty_impl, static_argnums=0)
        self._park_jit = jax.jit(self._park_objects_impl)
        self._take_jit = jax.jit(self._take_worlds_impl)

    # ------------------------------------------------------------------ buffers (warp)

    @property
    def contacts_per_world(self) -> int:
        return contacts_per_world(self.cfg)

    def buffer_sizes(self, n_worlds: int) -> tuple[int, int]:
        """(naconmax over all worlds, njmax per world) used for impl "warp"."""
        nacon = self.cfg.sim.naconmax or n_worlds * self.contacts_per_world
        njmax = self.cfg.sim.njmax or rows_per_contact(self.cfg) * self.contacts_per_world + 16
        return int(nacon), int(njmax)

    def _template(self, n_worlds: int) -> mjx.Data:
        key = n_worlds if self.impl == "warp" else 0
        if key not in self._template_cache:
            # Built eagerly (concrete arrays) even when first asked for inside a jit trace.
            with jax.ensure_compile_time_eval():
                self._template_cache[key] = self._make_template(n_worlds)
        return self._template_cache[key]

    def _make_template(self, n_worlds: int) -> mjx.Data:
        """One unbatched Data; for warp its buffers are sized for ``n_worlds`` worlds."""
        if self.impl == "warp":
            nacon, njmax = self.buffer_sizes(n_worlds)
            return mjx.make_data(self.scene.mj_model, impl="warp", naconmax=nacon, njmax=njmax)
        return mjx.make_data(self.mx, impl="jax")

    def _overflow_now(self, d: mjx.Data, B: int) -> jax.Array:
        """(B,) bool: a contact / constraint buffer is full after this step.

        Buffers and failures (never silently accepted):
        * impl "warp": contacts and constraint rows live in fixed buffers (``naconmax`` contacts over
          all worlds, ``njmax`` rows per world).  If ``cfg.sim.naconmax`` / ``njmax`` are None they
          are sized from the scene: only active objects and the gripper can touch anything (parked
          bodies are pinned far apart), so per world ``contacts_per_world`` = ``20 * N + 56``
          contacts unless set (each object on the table 4, object-object ~16 per object, 2 pads x
          up to 3 objects x 8 + pads on table) and ``3 * that + 16`` rows (6 * that + 16 when capsules or
          spheres, whose contacts have rolling friction (condim 6), are in the pool) (elliptic condim-3
          contacts use 3 rows, plus the finger equality and limits).
          After every step the simulator compares the contact count / rows with the buffers; a full
          buffer sets ``state.overflow`` for the world (for contacts: every world, the count is
          global).
        * impl "jax": MJX jax evaluates every candidate geom pair every step with a fixed number of
          contact slots per pair (for the default 20-body pool about 1000 contacts and 3000
          constraint rows per world, almost all between far-apart bodies).  The scene sets MJX's
          ``max_contact_points`` to ``contacts_per_world`` (same formula / config field as warp), so
          only the deepest contacts reach the solver.  Overflow = every kept contact penetrates
          (more may have been dropped): ``state.overflow``.  Tiny scenes with fewer candidate
          slots than the budget cannot overflow.  Numerical failures (NaNs, an object through the
          table) set ``state.error`` (both impls).
        Solver settings (ls_iterations 20, the 2 ms step of MJX jax, impratio 1 in ``tiny``): the
        measurements are in bench/RESULTS.md, "Environment throughput".
        Only NaNs and tunnelling are flagged (``error``); objects launched out of the workspace are
        deactivated (counted as lost by the evaluation), so keep ls_iterations at 20.
        ``check_overflow(state)`` (host side, between jitted calls) raises ``RuntimeError`` naming
        the worlds and what to change (or warns with ``warn=True``).  Inside a jitted training loop
        the flags are carried in the state: reset worlds whose ``error`` is set.
        """
        if self.impl != "warp":
            # MJX jax keeps the deepest max_contact_points contacts: full when all kept
            # contacts are penetrating (more may have been dropped).
            dist = d._impl.contact.dist  # noqa: SLF001  (B, ncon)
            if dist.shape[-1] < self.contacts_per_world:
                return jnp.zeros((B,), bool)  # every candidate pair has its slots
            return (dist.reshape(B, -1) < 0).sum(axis=1) >= dist.shape[-1]
        impl = d._impl  # noqa: SLF001
        nacon = jnp.max(jnp.asarray(impl.nacon))
        nefc = jnp.asarray(impl.nefc).reshape(B, -1).max(axis=1)
        full = (nacon >= impl.naconmax) | (nefc >= impl.njmax)
        # MuJoCo Warp's own per-world bitmask: constraint rows, broadphase, narrowphase /
        # contact, CCD and EPA buffers that were too small on this step.
        flags = jnp.asarray(impl.overflow).reshape(B, -1).max(axis=1)
        return full | ((flags & WARP_BUFFER_OVERFLOW_BITS) != 0)

    # ------------------------------------------------------------------ per-world sizes

    def object_bounds(self, obj_size):
        """Per-world bounds of every pool body: obj_size (B, P, 3) -> (aabb (B, P, 6) geom-frame
        centre + half size, rbound (B, P)).  Fixed shapes keep their compiled values."""
        aabb = jnp.broadcast_to(jnp.asarray(self._obj_aabb), obj_size.shape[:-1] + (6,))
        rbound = jnp.broadcast_to(jnp.asarray(self._obj_rbound), obj_size.shape[:-1])
        if not self._sized:
            return aabb, rbound
        phys = sized_body_physics(jnp.asarray(self.scene.object_kind), obj_size, self.cfg.scene.object_density)
        fixed = jnp.asarray(self._fixed)
        aabb = jnp.where(fixed[..., None], aabb, jnp.concatenate([jnp.zeros_like(obj_size), phys["aabb_half"]], -1))
        return aabb, jnp.where(fixed, rbound, phys["rbound"])

    def world_model(self, obj_size):
        """The model each world steps with -> (mjx.Model, vmap in_axes).

        With sized families, the object geoms' ``geom_size``, their bounds and their bodies'
        mass, inertia and inverse weights are per-world model fields (leading dim B; MJX jax
        and MuJoCo Warp both batch these); otherwise the shared model (in_axes None).
        """
        if not self._sized:
            return self.mx, None
        mx, sc = self.mx, self.scene
        B = obj_size.shape[0]
        fixed = jnp.asarray(self._fixed)
        phys = sized_body_physics(jnp.asarray(sc.object_kind), obj_size, self.cfg.scene.object_density)
        gid, bid = sc.object_geom_ids, sc.object_body_ids

        def per_world(field, rows, new):
            base = jnp.broadcast_to(field, (B,) + field.shape)
            keep = base[:, rows]
            f = fixed.reshape((1, -1) + (1,) * (keep.ndim - 2))
            return base.at[:, rows].set(jnp.where(f, keep, new.reshape(keep.shape).astype(field.dtype)))

        aabb = jnp.concatenate([jnp.zeros_like(obj_size), phys["aabb_half"]], -1)  # (B, P, 6)
        dof = sc.object_dof_adr[:, None] + np.arange(6)  # (P, 6)
        invw = phys["invweight"]
        dof_inv = jnp.repeat(invw, 3, axis=-1)  # (B, P, 6): 3 x translational, 3 x rotational
        fields = dict(
            geom_size=per_world(mx.geom_size, gid, obj_size),
            geom_rbound=per_world(mx.geom_rbound, gid, phys["rbound"]),
            geom_aabb=per_world(mx.geom_aabb, gid, aabb),
            body_mass=per_world(mx.body_mass, bid, phys["mass"]),
            body_inertia=per_world(mx.body_inertia, bid, phys["inertia"]),
            body_invweight0=per_world(mx.body_invweight0, bid, invw),
        )
        dof_b = jnp.broadcast_to(mx.dof_invweight0, (B,) + mx.dof_invweight0.shape)
        keep = dof_b[:, dof]  # (B, P, 6)
        fields["dof_invweight0"] = dof_b.at[:, dof].set(jnp.where(fixed[None, :, None], keep, dof_inv))
        axes = jax.tree.map(lambda _: None, mx).replace(**{k: 0 for k in fields})
        return mx.replace(**fields), axes

    def _stepper(self, obj_size):
        """-> step(d) advancing every world one physics step with its own model."""
        m, axes = self.world_model(obj_size)
        batched = jax.vmap(mjx.step, in_axes=(axes, 0))
        return lambda d: batched(m, d)

    def geom_size(self, state: SimState):
        """(B, ngeom, 3) per-world geom sizes for the renderer, or None when no size is drawn."""
        if not self._sized:
            return None
        base = jnp.broadcast_to(jnp.asarray(self.scene.mj_model.geom_size, jnp.float32),
                                (state.n_worlds,) + self.scene.mj_model.geom_size.shape)
        return base.at[:, self.scene.object_geom_ids].set(state.obj_size)

    # ------------------------------------------------------------------ low-level pieces

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

    def _drop_due(self, d: mjx.Data, active, t, drops: Drops, bounds):
        """Drop the bodies whose release step is ``t``: each is placed at rest with its bottom
        ``PILE_GAP`` above the highest top of the active bodies it may land on (bounding
        spheres overlapping in xy), or above the table.  bounds: ``object_bounds`` of the
        worlds' sizes.  -> (data, active (B, P))."""
        due = drops.release == t  # (B, P)
        ids = self.scene.object_geom_ids
        pos, rot = d.geom_xpos[:, ids], d.geom_xmat[:, ids]
        rz = rot[:, :, 2, :]
        aabb, rbound = bounds
        top = pos[..., 2] + (rz * aabb[..., :3]).sum(-1) + (jnp.abs(rz) * aabb[..., 3:]).sum(-1)  # (B, P)
        dist = jnp.linalg.norm(drops.xy[:, :, None] - pos[:, None, :, :2], axis=-1)  # (B, P new, P old)
        under = active[:, None, :] & (dist < drops.radius[:, :, None] + rbound[:, None, :])
        floor = jnp.where(under, top[:, None, :], self.cfg.workspace.table_z).max(axis=-1)  # (B, P)
        z = floor + drops.half_z + PILE_GAP
        pose = jnp.concatenate([drops.xy, z[..., None], drops.quat], axis=-1)  # (B, P, 7)
        q = d.qpos[:, self._obj_qidx]
        d = d.replace(qpos=d.qpos.at[:, self._obj_qidx].set(jnp.where(due[..., None], pose, q)),
                      qvel=d.qvel.at[:, self._obj_vidx].set(jnp.where(due[..., None], 0.0, d.qvel[:, self._obj_vidx])))
        return d, active | due

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

    # ------------------------------------------------------------------ reset

    def _sample_world(self, key, n):
        """One world's draw: n () int -> obj_qpos (P, 7), active (P,), rgb (P, 3) uint8,
        size (P, 3) geom_size.

        Sizes: each sized body's geom_size uniform in its range (``SceneModel.object_size_lo``
        .. ``hi``: box sides independently, capsule radius and length, sphere radius).
        Colours: a palette colour per body (distinct within the world for up to 10), each
        channel scaled by a factor in 1 +- ``colour_jitter``.  Placement (``Scene.placement``):
        "scatter": x, y uniform over the workspace shrunk by ``drop_margin``; "pile": uniform
        in a disc of radius ``pile_radius`` around a centre drawn like a scatter position.
        Either way bodies are spawned in draw order, each above every earlier one whose
        bounding sphere overlaps it in xy (no interpenetration), so overlapping ones are
        dropped one after another onto each other.
        """
        cfg, sc = self.cfg, self.scene
        P, N = self.P, self.N
        k_perm, k_xy, k_rot, k_col, k_size, k_jit, k_ctr = jax.random.split(key, 7)
        perm = jax.random.permutation(k_perm, P)  # perm[j] = j-th drawn body
        rank = jnp.argsort(perm)  # rank[i] = draw position of body i
        active = rank < n
        lo_s, hi_s = jnp.asarray(sc.object_size_lo), jnp.asarray(sc.object_size_hi)
        size = lo_s + jax.random.uniform(k_size, (P, 3)) * (hi_s - lo_s)
        xmin, xmax, ymin, ymax = cfg.workspace.bounds
        mg = cfg.scene.drop_margin
        lo = jnp.array([xmin + mg, ymin + mg])
        hi = jnp.array([xmax - mg, ymax - mg])
        if cfg.scene.placement == "pile":
            centre = jax.random.uniform(k_ctr, (2,), minval=lo, maxval=hi)
            k_r, k_t = jax.random.split(k_xy)
            r = cfg.scene.pile_radius * jnp.sqrt(jax.random.uniform(k_r, (P,)))
            t = 2 * jnp.pi * jax.random.uniform(k_t, (P,))
            xy = centre + jnp.stack([r * jnp.cos(t), r * jnp.sin(t)], axis=1)
        else:
            xy = jax.random.uniform(k_xy, (P, 2), minval=lo, maxval=hi)
        slot = perm[:N]
        park = jnp.asarray(sc.park_qpos)
        if cfg.scene.placement == "pile":
            quat, half_z = self._pile_orientations(k_rot, size)
            _, radius = self.object_bounds(size[None])
            release = jnp.where(active, rank * self.pile_release_interval, -1).astype(jnp.int32)
            drops = Drops(release=release, xy=xy, quat=quat, half_z=half_z, radius=radius[0])
            obj_qpos = park  # every body waits parked for its drop
        else:
            quat = jax.random.normal(k_rot, (P, 4))
            quat = quat / jnp.linalg.norm(quat, axis=1, keepdims=True)
            z = self._scatter_spawn(size, xy, slot)
            drops = Drops(release=jnp.full((P,), -1, jnp.int32), xy=xy, quat=quat,
                          half_z=jnp.zeros(P), radius=jnp.zeros(P))
            obj_qpos = jnp.where(active[:, None], jnp.concatenate([xy, z[:, None], quat], axis=1), park)
        colours = jax.random.permutation(k_col, sc.palette.shape[0])
        base_rgb = jnp.asarray(sc.palette, jnp.float32)[colours[rank % sc.palette.shape[0]]]
        j = cfg.scene.colour_jitter
        scale = jax.random.uniform(k_jit, (P, 3), minval=1.0 - j, maxval=1.0 + j)
        rgb = jnp.clip(jnp.round(base_rgb * scale), 0, 255).astype(jnp.uint8)
        return obj_qpos, active, rgb, size.astype(jnp.float32), drops

    def _scatter_spawn(self, size, xy, slot):
        """Spawn heights (P,) for "scatter": centres at ``drop_height`` (or higher), each body
        above every earlier-drawn one whose bounding sphere overlaps it in xy."""
        cfg, sc, N = self.cfg, self.scene, self.N
        _, radius = self.object_bounds(size[None])
        radius = jnp.where(jnp.asarray(self._fixed), jnp.asarray(sc.object_radius), radius[0])
        sxy, sr = xy[slot], radius[slot]
        base = cfg.workspace.table_z + jnp.maximum(cfg.scene.drop_height, sr + SPAWN_GAP)

        def place(j, z):
            dist = jnp.linalg.norm(sxy - sxy[j], axis=1)
            overlap = (jnp.arange(N) < j) & (dist < sr + sr[j] + SPAWN_GAP)
            above = jnp.where(overlap, z + sr + sr[j] + SPAWN_GAP, -jnp.inf).max()
            return z.at[j].set(jnp.maximum(base[j], above))

        sz = jax.lax.fori_loop(0, N, place, jnp.zeros(N))
        return jnp.zeros(self.P).at[slot].set(sz)

    def _pile_orientations(self, key, size):
        """Drop orientations (P, 4) wxyz for "pile" and the half heights (P,) of the bodies'
        world bounding boxes in them: each body lies on a random face (x, y or z axis up),
        tilted up to ``PILE_TILT`` rad about a random horizontal axis, at a random yaw."""
        P = self.P
        k_face, k_tilt_axis, k_tilt, k_yaw = jax.random.split(key, 4)
        s2 = np.sqrt(0.5)
        faces = jnp.array([[1.0, 0, 0, 0], [s2, 0, -s2, 0], [s2, s2, 0, 0]])  # z up, x up, y up
        q_face = faces[jax.random.randint(k_face, (P,), 0, 3)]
        phi = 2 * jnp.pi * jax.random.uniform(k_tilt_axis, (P,))
        tilt = PILE_TILT * jax.random.uniform(k_tilt, (P,))
        q_tilt = jnp.stack([jnp.cos(tilt / 2), jnp.cos(phi) * jnp.sin(tilt / 2),
                            jnp.sin(phi) * jnp.sin(tilt / 2), jnp.zeros(P)], -1)
        yaw = 2 * jnp.pi * jax.random.uniform(k_yaw, (P,))
        q_yaw = jnp.stack([jnp.cos(yaw / 2), jnp.zeros(P), jnp.zeros(P), jnp.sin(yaw / 2)], -1)
        quat = _quat_mul(q_yaw, _quat_mul(q_tilt, q_face))
        aabb, _ = self.object_bounds(size[None])
        rz = _quat_to_mat(quat)[:, 2, :]  # (P, 3) world z of each body axis
        half_z = (jnp.abs(rz) * aabb[0, :, 3:]).sum(-1) + (rz * aabb[0, :, :3]).sum(-1)
        return quat, half_z

    def _start_rounds(self, state: SimState, mask, keys, n_objects):
        """Worlds with mask (B,) get a new scene drawn with keys (B, 2) and n_objects (B,):
        new sizes and colours, flags cleared, objects placed at their spawn poses at rest
        ("scatter") or parked until their drop ("pile"; returned ``Drops``).  No physics: the
        caller lets the scene settle, passing the ``Drops`` to its loop.  The other worlds are
        unchanged.  -> (SimState, Drops, or None for "scatter", where nothing is dropped later)."""
        d = state.data
        obj_qpos, active, rgb, size, drops = jax.vmap(self._sample_world)(keys, n_objects)
        m3 = mask[:, None, None]
        drops = drops.replace(release=jnp.where(mask[:, None], drops.release, -1))
        placed = active & (drops.release < 0)  # scatter: every drawn body; pile: none yet
        d = d.replace(
            qpos=d.qpos.at[:, self._obj_qidx].set(jnp.where(m3, obj_qpos, d.qpos[:, self._obj_qidx])),
            qvel=d.qvel.at[:, self._obj_vidx].set(jnp.where(m3, 0.0, d.qvel[:, self._obj_vidx])),
            qacc_warmstart=jnp.where(mask[:, None], 0.0, d.qacc_warmstart),
        )
        d = self._wake(d, mask)
        ids = self.scene.object_geom_ids
        state = state.replace(
            data=d,
            active=jnp.where(mask[:, None], placed, state.active),
            geom_rgb=state.geom_rgb.at[:, ids].set(jnp.where(m3, rgb, state.geom_rgb[:, ids])),
            n_objects=jnp.where(mask, n_objects.astype(jnp.int32), state.n_objects),
            error=state.error & ~mask, overflow=state.overflow & ~mask,
            obj_size=jnp.where(m3, size, state.obj_size),
        )
        return state, (drops if self.cfg.scene.placement == "pile" else None)

    def _reset_impl(self, keys, n_objects) -> SimState:
        B = keys.shape[0]
        state, drops = self._start_rounds(self._empty_impl(B), jnp.ones((B,), bool), keys, n_objects)
        park_ctrl = self._park_ctrl(B)
        d, active, ovf = self._run(state.data, state.active, state.overflow, lambda _: park_ctrl,
                                   jnp.zeros((self.n_settle_reset,)), state.obj_size, drops)
        return self._housekeep(state.replace(data=d, active=active, overflow=ovf))

    def reset(self, key, n_objects) -> SimState:
        """New scenes.  key: (2,) or (B, 2) uint32 (or typed key () / (B,)); n_objects: (B,) int.

        Concrete n_objects outside 1..N raise ValueError; traced ones (inside an outer jit)
        are not checked.  Returns a SimState with B worlds.
        """
        if jnp.issubdtype(jnp.asarray(key).dtype, jax.dtypes.prng_key):
            key = jax.random.key_data(key)
        n_arr = jnp.asarray(n_objects)
        if not _is_traced(n_objects):
            n_np = np.asarray(n_objects)
            if not np.issubdtype(n_np.dtype, np.integer) or n_np.ndim > 1 or n_np.size == 0 \
                    or n_np.min() < 1 or n_np.max() > self.N:
                raise ValueError(
                    f"n_objects must be integers in 1..{self.N} (Config.scene.max_objects = "
                    f"{self.N}), one per world as a (B,) array; got {n_np.tolist()!r}"
                )
        n_arr = jnp.atleast_1d(n_arr).astype(jnp.int32)
        key = jnp.asarray(key)
        if key.ndim == 1:
            keys = jax.random.split(key, n_arr.shape[0])
        elif key.ndim == 2:
            keys = key
            if n_arr.shape[0] == 1 and keys.shape[0] > 1:
                n_arr = jnp.broadcast_to(n_arr, (keys.shape[0],))
            if keys.shape[0] != n_arr.shape[0]:
                raise ValueError(
                    f"reset: key has {keys.shape[0]} worlds but n_objects has {n_arr.shape[0]}"
                )
        else:
            raise ValueError(f"reset: key must have shape (2,) or (B, 2), got {key.shape}")
        return self._reset_jit(keys, n_arr)

    # ------------------------------------------------------------------ grasp

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

    # ------------------------------------------------------------------ helpers

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

    check_overflow = staticmethod(check_overflow)
