"""The VAGS environment: batched worlds observed as heightmaps, grasped in heightmap coordinates.

``VagsEnv(cfg)`` builds the scene, the simulator and the renderer once.  Its state is an
``EnvState`` over B worlds holding the physics state, the latest *global-view* heightmaps and the
round's bookkeeping.  Public methods validate their inputs and are jit-compiled; the methods
whose names start with ``step_`` / ``observe`` / ``reset_where`` are pure and jittable, for use
inside a larger jitted loop (``vags_jax.stages.stage1``).

Grasp in heightmap coordinates (``grasp(state, pixel, rotation)``):
  * ``pixel`` = (row, col) of the global heightmap -> world x, y of the cell centre;
  * the grasp centre is ``depth_below_surface`` under the surface height at that cell (never
    below ``table_z + min_height_above_table``, enforced by the simulator);
  * ``rotation`` r -> closing-axis yaw ``r * grasp.rotation_step``: ``r * pi / (n_rotations / 2)``,
    or ``r * pi / n_rotations`` with ``grasp.half_turn`` (config conventions).

One grasp attempt = the physics of the grasp, then a new global observation (render +
heightmaps) of every world.  A *round* is one scene: it ends when the table is clear or after
``2 * objects + max_attempts_extra`` attempts (``round_over``).
"""
from __future__ import annotations

import math
from typing import Optional

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from vags_jax.perception import camera
from vags_jax.config import Config
from vags_jax.sim.scene import build_scene
from vags_jax.env.observation import CameraImage, Observation
from vags_jax.sim.simulator import GraspResult, SimState, Simulator, check_overflow


@struct.dataclass
class EnvState:
    """B worlds.

    sim: physics state (``vags_jax.sim.simulator.SimState``).
    color: (B, H, W, 3) uint8 colour heightmap of the latest global view.
    height: (B, H, W) float32 height heightmap (m above the table) of that view.
    attempts: (B,) int32 grasp attempts in the current round.
    successes: (B,) int32 successful grasps in the current round.
    motions: (B,) int32 camera / gripper motions in the current round.
    travel: (B,) float32 commanded gripper travel (m) in the current round.
    """

    sim: SimState
    color: jax.Array
    height: jax.Array
    attempts: jax.Array
    successes: jax.Array
    motions: jax.Array
    travel: jax.Array

    @property
    def n_worlds(self) -> int:
        return self.height.shape[0]



@struct.dataclass
class Attempt:
    """One planned grasp attempt per world (B worlds).

    position: (B, 3) world grasp point (fingertip centre); yaw: (B,) closing-axis angle (rad);
    start: (B, 3) hand position where the grasp's approach begins: where the last image was
    captured (the global pose, or the viewpoint the camera moved to); motions: (B,) int32
    camera or gripper motions of the attempt (1 = grasp from the global view, 2 = one viewpoint
    move then the grasp, more for multi-view methods); view_travel: (B,) float32 metres the
    hand travelled for those camera moves before the grasp.
    """

    position: jax.Array
    yaw: jax.Array
    start: jax.Array
    motions: jax.Array
    view_travel: jax.Array
    # (B,) float32 the planner's decision value (VAGS: GDNet's largest Q on the global view,
    # which the threshold is compared with), recorded by the benchmark; None for planners
    # without one.
    score: Optional[jax.Array] = None
    # (B,) bool: the world pushes instead (VPG; ``vags_jax.env.push``: position = where the
    # fingertips start, yaw = the push direction); None for planners that only grasp.
    push: Optional[jax.Array] = None


def grasp_pose(cfg: Config, height: jax.Array, pixel: jax.Array, rotation: jax.Array):
    """Heightmap action -> (position (B, 3), yaw (B,)) in the world frame: pixel (B, 2) [row, col]
    of the height maps (B, H, W), rotation (B,) index.  x, y: the cell centre; z:
    ``grasp.depth_below_surface`` under the surface height there; yaw: ``rotation *
    grasp.rotation_step`` (the closing axis, config conventions)."""
    xy = camera.pixel_to_world_xy(pixel, cfg.workspace)
    b = jnp.arange(height.shape[0])
    surface = height[b, pixel[:, 0], pixel[:, 1]]
    z = cfg.workspace.table_z + surface - cfg.grasp.depth_below_surface
    yaw = rotation.astype(jnp.float32) * cfg.grasp.rotation_step
    return jnp.concatenate([xy, z[:, None]], axis=1), yaw


def select_attempt(mask: jax.Array, a: Attempt, b: Attempt) -> Attempt:
    """Per world: attempt ``a`` where mask (B,) is set, else ``b``."""
    return jax.tree.map(lambda x, y: jnp.where(mask.reshape((-1,) + (1,) * (x.ndim - 1)), x, y), a, b)


class VagsEnv(Observation):
    """Scene + simulator + renderer for one config.  Build once, reuse for any batch size."""

    def __init__(self, cfg: Config):
        self.cfg = cfg
        self.scene = build_scene(cfg)
        self.sim = Simulator(cfg, self.scene)
        self._geometry: dict[int, object] = {}
        self.global_pose = np.asarray(camera.global_pose(cfg.camera), np.float32)
        # Every reset outside a traced program runs this one compiled program (``reset_unchecked``
        # splits the key first), so that training's resets and the benchmark's share it.
        self._reset_worlds_jit = jax.jit(self.step_reset_worlds)
        self._redrop_worlds_jit = jax.jit(self.step_redrop_worlds)
        self._grasp_jit = jax.jit(self.step_grasp)
        self._grasp_world_jit = jax.jit(self.step_grasp_world)
        self._observe_jit = jax.jit(self.observe)

    # ------------------------------------------------------------------ helpers

    def max_attempts(self, n_objects: jax.Array, extra: Optional[int] = None) -> jax.Array:
        """(B,) attempts allowed in a round that started with n_objects (B,):
        ``2 * n_objects + extra`` (default ``stage1.max_attempts_extra``; the benchmark passes
        ``benchmark.max_attempts_extra``)."""
        return 2 * n_objects + (self.cfg.stage1.max_attempts_extra if extra is None else extra)

    @staticmethod
    def n_remaining(state: EnvState) -> jax.Array:
        """(B,) int32 objects still on the table."""
        return state.sim.active.sum(axis=1).astype(jnp.int32)

    @classmethod
    def knocked_off(cls, before: EnvState, after: EnvState, success: jax.Array) -> jax.Array:
        """(B,) int32 objects that left the table between ``before`` and ``after`` without being
        grasped (success (B,) bool: one object grasped)."""
        return cls.n_remaining(before) - cls.n_remaining(after) - success.astype(jnp.int32)

    def round_over(self, state: EnvState, extra: Optional[int] = None) -> jax.Array:
        """(B,) bool: table clear, or the round's attempt budget (``max_attempts``) is used up."""
        return (self.n_remaining(state) == 0) | (state.attempts >= self.max_attempts(state.sim.n_objects, extra))

    # ------------------------------------------------------------------ pure, jittable

    def step_reset(self, key: jax.Array, n_objects: jax.Array, observe: bool = True) -> EnvState:
        """New rounds in every world: key (2,) raw uint32, n_objects (B,) int32 (unchecked).

        With ``observe=False`` the heightmaps are left at zero (the caller observes later).
        """
        k_sim, k_obs = jax.random.split(key)
        B = n_objects.shape[0]
        return self.step_reset_worlds(jax.random.split(k_sim, B), n_objects, k_obs, observe)

    def step_reset_worlds(self, keys: jax.Array, n_objects: jax.Array, obs_key: jax.Array,
                          observe: bool = True) -> EnvState:
        """``step_reset`` with one scene key per world: keys (B, 2), n_objects (B,) int32,
        obs_key (2,) the observation's sensor-noise key.  A world's scene depends only on its
        key, so worlds of different batches can be given the scenes of one ``step_reset``."""
        B = n_objects.shape[0]
        k_obs = obs_key
        sim_state = self.sim.reset_batched(keys, n_objects)
        H = self.cfg.workspace.heightmap_px
        if observe:
            color, height = self.observe_global(sim_state, k_obs)
        else:
            color, height = jnp.zeros((B, H, H, 3), jnp.uint8), jnp.zeros((B, H, H), jnp.float32)
        zi = jnp.zeros((B,), jnp.int32)
        return EnvState(sim=sim_state, color=color, height=height, attempts=zi, successes=zi,
                        motions=zi, travel=jnp.zeros((B,), jnp.float32))

    def step_redrop_worlds(self, state: EnvState, keys: jax.Array, n_objects: jax.Array,
                           obs_key: jax.Array) -> EnvState:
        """Fresh rounds of ``step_reset_worlds(keys, n_objects, ...)`` with their spilled
        objects dropped onto their piles again (``Simulator.redrop_batched``), observed anew with
        obs_key (2,).  The counters stay as they are (zero in fresh rounds)."""
        sim_state = self.sim.redrop_batched(state.sim, keys, n_objects)
        color, height = self.observe_global(sim_state, obs_key)
        return state.replace(sim=sim_state, color=color, height=height)

    def redrop_worlds(self, state: EnvState, keys: jax.Array, n_objects: jax.Array, obs_key: jax.Array) -> EnvState:
        """``step_redrop_worlds`` compiled (unchecked)."""
        return self._redrop_worlds_jit(state, keys, n_objects, obs_key)

    def reset_where(self, key: jax.Array, state: EnvState, mask: jax.Array, n_objects: jax.Array,
                    observe: bool = True) -> EnvState:
        """Worlds with mask (B,) set start a new round with n_objects (B,); the rest are kept.

        The reset physics is skipped entirely when no world needs it.  With ``observe=False``
        the reset worlds' heightmaps are stale until the caller observes.
        """
        def do_reset(s):
            return where_worlds(mask, self.step_reset(key, n_objects, observe), s)

        return jax.lax.cond(mask.any(), do_reset, lambda s: s, state)

    def with_observation(self, state: EnvState, key: Optional[jax.Array] = None) -> EnvState:
        """state with fresh global-view heightmaps of every world."""
        color, height = self.observe_global(state.sim, key)
        return state.replace(color=color, height=height)

    def grasp_pose(self, state: EnvState, pixel: jax.Array, rotation: jax.Array):
        """Heightmap action -> (position (B, 3), yaw (B,)) in the world frame (``grasp_pose``)."""
        return grasp_pose(self.cfg, state.height, pixel, rotation)

    def _start(self, n_worlds: int) -> jax.Array:
        """(B, 3) hand position before a grasp: where the global view was captured."""
        return jnp.broadcast_to(jnp.asarray(self.cfg.camera.global_position, jnp.float32), (n_worlds, 3))

    def viewpoint_pose(self, state: EnvState, pixel: jax.Array) -> jax.Array:
        """(B, 4, 4) camera pose ``camera.viewpoint_height`` above the global heightmap's surface at
        pixel (B, 2) [row, col], looking straight down (``camera.viewpoint_pose``)."""
        return camera.viewpoint_pose(pixel, state.height, self.cfg.workspace, self.cfg.camera)

    def global_poses(self, n_worlds: int) -> jax.Array:
        """(B, 4, 4) the global camera pose for every world."""
        return jnp.broadcast_to(jnp.asarray(self.global_pose), (n_worlds, 4, 4))

    def direct_attempt(self, position: jax.Array, yaw: jax.Array) -> Attempt:
        """A grasp planned on the global view: from the global pose, 1 motion."""
        B = position.shape[0]
        return Attempt(position=position, yaw=yaw, start=self._start(B), motions=jnp.ones((B,), jnp.int32),
                       view_travel=jnp.zeros((B,), jnp.float32))

    def viewpoint_attempt(self, position: jax.Array, yaw: jax.Array, view_pose: jax.Array) -> Attempt:
        """A grasp planned on a close view taken at view_pose (B, 4, 4): the hand first moves
        from the global pose to the viewpoint (1 motion, its distance counted), captures, then
        grasps with the approach starting there (the 2nd motion)."""
        B = position.shape[0]
        view = view_pose[:, :3, 3]
        return Attempt(position=position, yaw=yaw, start=view, motions=jnp.full((B,), 2, jnp.int32),
                       view_travel=jnp.linalg.norm(view - self._start(B), axis=1))

    def _after_grasp(self, state: EnvState, sim_state: SimState, result: GraspResult, key,
                     motions, observe: bool, grasped: Optional[jax.Array] = None,
                     view_travel: Optional[jax.Array] = None) -> EnvState:
        """Round bookkeeping (+1 attempt where ``grasped``, (B,) bool, default all; + ``motions``,
        an int or (B,) int32; travel + the grasp's + ``view_travel`` (B,)) and the new global
        view.  Worlds that did not grasp (they were reset) start from zero."""
        state = state.replace(sim=sim_state)
        if observe:
            state = self.with_observation(state, key)
        g = jnp.ones((state.n_worlds,), bool) if grasped is None else grasped
        zi = jnp.zeros((state.n_worlds,), jnp.int32)
        extra = 0.0 if view_travel is None else view_travel
        return state.replace(
            attempts=jnp.where(g, state.attempts + 1, zi),
            successes=jnp.where(g, state.successes + result.success.astype(jnp.int32), zi),
            motions=jnp.where(g, state.motions + motions, zi),
            travel=jnp.where(g, state.travel + result.approach + result.descend + result.lift + extra, 0.0),
        )

    def step_attempt(self, state: EnvState, attempt: Attempt, key: Optional[jax.Array] = None,
                     observe: bool = True):
        """Execute one planned attempt per world (each world on its own branch: direct or after
        a viewpoint move), then (``observe``) re-observe the global view.  Returns
        (EnvState, GraspResult); ``GraspResult.approach`` runs from ``attempt.start``."""
        sim_state, result = self.sim.grasp_batched(state.sim, attempt.position, attempt.yaw, attempt.start)
        state = self._after_grasp(state, sim_state, result, key, attempt.motions, observe,
                                  view_travel=attempt.view_travel)
        return state, result

    def step_grasp_world(self, state: EnvState, position: jax.Array, yaw: jax.Array,
                         key: Optional[jax.Array] = None, motions: int = 1, observe: bool = True):
        """Grasp at world position (B, 3) / yaw (B,) from the global view, then (``observe``)
        re-observe it; the attempt counts ``motions``."""
        attempt = self.direct_attempt(position, yaw)
        return self.step_attempt(state, attempt.replace(motions=jnp.full_like(attempt.motions, motions)), key, observe)

    def step_grasp(self, state: EnvState, pixel: jax.Array, rotation: jax.Array,
                   key: Optional[jax.Array] = None, observe: bool = True):
        """Grasp at heightmap pixel (B, 2) [row, col] with rotation index (B,) (unchecked)."""
        position, yaw = self.grasp_pose(state, pixel, rotation)
        return self.step_grasp_world(state, position, yaw, key, observe=observe)

    def step_grasp_or_reset(self, state: EnvState, pixel: jax.Array, rotation: jax.Array,
                            reset: jax.Array, reset_key: jax.Array, n_objects: jax.Array,
                            key: Optional[jax.Array] = None, observe: bool = True):
        """One env step for a training loop: worlds with ``reset`` (B,) bool start a new round
        of n_objects (B,) int32 (their action is ignored, their GraspResult is a failure), the
        others grasp at pixel (B, 2) / rotation (B,).  The new scenes settle during the same
        physics loop as the grasps, so a reset costs no extra simulated time for the batch.
        reset_key: (2,) raw uint32.  Returns (state, GraspResult)."""
        position, yaw = self.grasp_pose(state, pixel, rotation)
        return self.step_attempt_or_reset(state, self.direct_attempt(position, yaw), reset, reset_key,
                                          n_objects, key, observe)

    def step_attempt_or_reset(self, state: EnvState, attempt: Attempt, reset: jax.Array,
                              reset_key: jax.Array, n_objects: jax.Array,
                              key: Optional[jax.Array] = None, observe: bool = True):
        """``step_grasp_or_reset`` for planned attempts (direct or after a viewpoint move, each
        world on its own branch): worlds with ``reset`` (B,) start a new round of n_objects (B,)
        instead.  Returns (state, GraspResult)."""
        B = state.n_worlds
        sim_state, result = self.sim.grasp_or_reset_batched(
            state.sim, attempt.position, attempt.yaw, attempt.start, reset, jax.random.split(reset_key, B),
            n_objects)
        state = self._after_grasp(state, sim_state, result, key, attempt.motions, observe, grasped=~reset,
                                  view_travel=attempt.view_travel)
        return state, result

    # ------------------------------------------------------------------ public, validated

    def reset(self, key, n_objects, check_buffers: bool = True) -> EnvState:
        """New scenes: key (2,) uint32 PRNG key, n_objects (B,) ints in 1..max_objects.
        check_buffers: read the worlds' buffer-overflow and physics-error flags and warn (this
        waits for the reset to finish); False returns as soon as the reset is dispatched, for
        callers that report the flags later (train.py's stages warn from their metrics:
        ``driver.run_chunks``)."""
        n = np.asarray(n_objects)
        N = self.cfg.scene.max_objects
        if n.ndim != 1 or n.size == 0 or not np.issubdtype(n.dtype, np.integer) or n.min() < 1 or n.max() > N:
            raise ValueError(
                f"n_objects must be a (B,) array of integers in 1..{N} (scene.max_objects = {N}); "
                f"got {n.tolist()!r}"
            )
        state = self.reset_unchecked(_raw_key(key), jnp.asarray(n, jnp.int32))
        if check_buffers:
            check_overflow(state.sim, warn=True)  # warns, naming the worlds; they can be reset again
        return state

    def reset_unchecked(self, key: jax.Array, n_objects: jax.Array) -> EnvState:
        """``step_reset``'s worlds (the same keys, so the same scenes) from the compiled
        ``reset_worlds``: key (2,) raw uint32, n_objects (B,) int32, unchecked."""
        k_sim, k_obs = jax.random.split(key)
        return self.reset_worlds(jax.random.split(k_sim, n_objects.shape[0]), n_objects, k_obs)

    def reset_worlds(self, keys: jax.Array, n_objects: jax.Array, obs_key: jax.Array) -> EnvState:
        """``step_reset_worlds`` compiled (unchecked): keys (B, 2), n_objects (B,) int32, obs_key (2,)."""
        self.prepare(n_objects.shape[0])
        return self._reset_worlds_jit(keys, n_objects, obs_key)

    def grasp(self, state: EnvState, pixel, rotation, key=None):
        """Grasp in every world at heightmap pixel (B, 2) [row, col], rotation index (B,).

        Returns (EnvState, GraspResult).  Raises ValueError for pixels outside the heightmap or
        rotation indices outside 0..n_rotations-1.
        """
        B, H = state.n_worlds, self.cfg.workspace.heightmap_px
        R = self.cfg.grasp.n_rotations
        pixel = np.asarray(pixel)
        rotation = np.asarray(rotation)
        if pixel.shape != (B, 2) or not np.issubdtype(pixel.dtype, np.integer):
            raise ValueError(f"pixel must be a (B, 2) = ({B}, 2) integer array of [row, col]; "
                             f"got shape {pixel.shape} dtype {pixel.dtype}")
        if pixel.min() < 0 or pixel.max() >= H:
            bad = pixel[(pixel < 0).any(1) | (pixel >= H).any(1)]
            raise ValueError(f"pixel [row, col] must lie in 0..{H - 1} (heightmap is {H} x {H}); "
                             f"got {bad[:4].tolist()}")
        if rotation.shape != (B,) or not np.issubdtype(rotation.dtype, np.integer):
            raise ValueError(f"rotation must be a (B,) = ({B},) integer array; got shape "
                             f"{rotation.shape} dtype {rotation.dtype}")
        if rotation.min() < 0 or rotation.max() >= R:
            wrong = rotation[(rotation < 0) | (rotation >= R)][:4].tolist()
            raise ValueError(f"rotation index must lie in 0..{R - 1} ({R} rotations of "
                             f"{math.degrees(self.cfg.grasp.rotation_step):.1f} deg); got {wrong}")
        key = None if key is None else _raw_key(key)
        state, result = self._grasp_jit(state, jnp.asarray(pixel, jnp.int32), jnp.asarray(rotation, jnp.int32), key)
        check_overflow(state.sim)
        return state, result

    def grasp_at(self, state: EnvState, position, yaw, key=None):
        """Grasp in every world at world position (B, 3) with closing-axis yaw (B,) radians."""
        B = state.n_worlds
        position = jnp.asarray(position, jnp.float32)
        yaw = jnp.asarray(yaw, jnp.float32)
        if position.shape != (B, 3) or yaw.shape != (B,):
            raise ValueError(f"grasp_at expects position ({B}, 3) and yaw ({B},); got "
                             f"{position.shape} and {yaw.shape}")
        key = None if key is None else _raw_key(key)
        state, result = self._grasp_world_jit(state, position, yaw, key)
        check_overflow(state.sim)
        return state, result


def where_worlds(mask: jax.Array, a, b):
    """Per world: ``a`` where mask (B,) is set, else ``b`` (two pytrees of the same structure).

    Leaves without a leading world dimension -- impl "warp" carries buffers shared by all
    worlds (contacts, counters), rebuilt on every step -- are taken from ``b``.
    """
    B = mask.shape[0]

    def pick(x, y):
        if x.ndim == 0 or x.shape[0] != B or x.shape != y.shape:
            return y
        return jnp.where(mask.reshape((-1,) + (1,) * (x.ndim - 1)), x, y)

    return jax.tree.map(pick, a, b)


def _raw_key(key) -> jax.Array:
    key = jnp.asarray(key)
    if jnp.issubdtype(key.dtype, jax.dtypes.prng_key):
        key = jax.random.key_data(key)
    if key.shape != (2,):
        raise ValueError(f"expected one PRNG key of shape (2,) (jax.random.PRNGKey(seed)); got {key.shape}")
    return key


__all__ = ["EnvState", "VagsEnv", "GraspResult", "CameraImage", "Attempt", "grasp_pose", "select_attempt",
           "where_worlds"]
