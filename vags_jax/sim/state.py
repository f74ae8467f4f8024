"""The simulator's state and results: ``SimState`` (B worlds), ``GraspResult``, ``Drops`` of
pile scenes, and the host-side ``check_overflow``."""
from __future__ import annotations

import warnings

import jax
import numpy as np
from flax import struct
from mujoco import mjx

# mujoco_warp OverflowType bits that mean a buffer was too small (data were dropped):
# NEFC, NJMAX_NNZ, BROADPHASE, NARROWPHASE, CCD, EPA_HORIZON.  Solver / line-search iteration
# limits (bits 9, 10) are convergence warnings, not dropped data.
WARP_BUFFER_OVERFLOW_BITS = (1 << 0) | (1 << 1) | (1 << 2) | (1 << 3) | (1 << 4) | (1 << 8)


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
