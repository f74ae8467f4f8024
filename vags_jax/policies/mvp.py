"""Multi-View Picking (MVP, Morrison et al. 2019) as a benchmark policy: ``eval.py --policy mvp``.

One attempt, per world (config ``mvp``, ``config.Mvp``; the grid math is ``mvp_grid``):

1. GG-CNN on the raw depth image of the global camera (the capture every method starts from);
   every pixel's quality and angle is counted into the cell its surface point falls in.
2. The camera moves straight above the workspace centre, ``mvp.start_height`` above the table,
   looking down (the first camera move), and takes a view.
3. View steps, a fixed number (``Mvp.view_steps``) in one ``lax.scan``, masked per world: after
   each view, the information gain (each cell's quality-histogram entropy, blurred by the
   camera's footprint) less the height-weighted distance cost to the best grasp picks the best
   cell within ``greedy_window``; the camera moves ``step`` towards it and down.  A world stops
   viewing when the next step would take the camera below ``stop_height``.
4. The best fused grasp (``mvp_grid.best_grasp``) is executed, its approach starting where the
   camera stopped.

Every camera move is a motion: ``Attempt.motions`` = 1 (the grasp) + the moves, and
``view_travel`` their distance, so the benchmark's time model charges a capture per view and the
travel.  The failure map (B, N, N) is the policy's memory over a round (``Policy.init_memory`` /
``remember``): every failed grasp adds a Gaussian of ``failure_sigma`` at its position, which is
subtracted from the grid's quality in the round's later attempts.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp
from flax import struct

from vags_jax.config import Config
from vags_jax.env import Attempt, EnvState, VagsEnv
from vags_jax.ggcnn.planner import image_to_world, network_input
from vags_jax.ggcnn.process import postprocess
from vags_jax.nets.ggcnn import GGCNN
from vags_jax.perception import camera
from vags_jax.policies import mvp_grid as G


@struct.dataclass
class ViewPath:
    """The views of one attempt: position (T, B, 3) the camera's world position at each view
    step; taken (T, B) bool whether the world took that view (it stops once the next step
    would go below ``stop_height``)."""

    position: jax.Array
    taken: jax.Array


@struct.dataclass
class _Walk:
    grid: G.ViewGrid
    position: jax.Array  # (B, 3)
    active: jax.Array  # (B,) bool: the world takes the view at ``position``
    moves: jax.Array  # (B,) int32 camera moves so far
    travel: jax.Array  # (B,) float32 metres of camera moves


class MvpPlanner:
    """MVP for one config.  ``params``: GG-CNN's ``{"params"}``.  ``plan(params, key, env, state,
    failures) -> Attempt``; ``init_memory(B)`` the empty failure map (B, N, N);
    ``remember(failures, attempt, success)`` adds the failed attempts' grasps to it."""

    def __init__(self, cfg: Config):
        self.cfg = cfg
        self.model = GGCNN()
        self.n = G.grid_size(cfg.workspace, cfg.mvp)
        self.cell = cfg.workspace.size / self.n
        self.steps = cfg.mvp.view_steps()
        crop = cfg.ggcnn.crop_size or min(cfg.camera.width, cfg.camera.height)
        self.view_width = crop / cfg.camera.fx  # footprint width per metre of camera height

    def init_memory(self, n_worlds: int) -> jax.Array:
        return jnp.zeros((n_worlds, self.n, self.n), jnp.float32)

    def remember(self, failures: jax.Array, attempt: Attempt, success: jax.Array) -> jax.Array:
        return G.add_failure(failures, attempt.position[:, :2], ~success, self.cfg.workspace,
                             self.cfg.mvp.failure_sigma)

    def observe(self, grid: G.ViewGrid, params, depth: jax.Array, pose: jax.Array, mask: jax.Array) -> G.ViewGrid:
        """GG-CNN on depth (B, h, w) taken at pose (B, 4, 4): every valid pixel of the worlds with
        mask (B,) set counted into the grid."""
        cfg = self.cfg
        x, filled, k_in, valid = network_input(depth, cfg.camera, cfg.ggcnn)
        quality, angle, _ = postprocess(self.model.apply(params, x), cfg.ggcnn)
        B, S, _ = filled.shape
        v, u = jnp.meshgrid(jnp.arange(S), jnp.arange(S), indexing="ij")
        pixel = jnp.broadcast_to(jnp.stack([u, v], -1).reshape(1, S * S, 2), (B, S * S, 2))
        g = image_to_world(pixel, angle.reshape(B, -1), jnp.zeros((B, S * S)), filled, k_in, pose, 0.0)
        ok = valid.reshape(B, -1) & mask[:, None]
        return G.add_observations(grid, g.position, quality.reshape(B, -1), g.yaw, ok, cfg.workspace)

    def next_position(self, grid: G.ViewGrid, failures: jax.Array, position: jax.Array) -> jax.Array:
        """Where the camera at position (B, 3) goes next (before the stop rule)."""
        cfg, m = self.cfg, self.cfg.mvp
        centres = G.cell_centres(cfg.workspace, self.n)
        best_xy = G.best_grasp(grid, failures, cfg.workspace)[0]
        z_cam = position[:, 2] - cfg.workspace.table_z
        gain = G.blur(G.entropy(grid.qhist), G.footprint_sigma(z_cam, self.view_width, self.cell))
        value = gain - G.travel_cost(centres, best_xy, z_cam, m)
        return G.next_position(value, centres, position, m, cfg.workspace)

    def views(self, params, key, env: VagsEnv, state: EnvState, failures: jax.Array):
        """The viewing phase -> (the final ``_Walk``, ``ViewPath``)."""
        cfg, m = self.cfg, self.cfg.mvp
        B = state.n_worlds
        k_global, k_steps = jax.random.split(key)
        grid = G.init_grid(B, self.n, m)
        g_pose = env.global_poses(B)
        grid = self.observe(grid, params, env.camera_image(state.sim, g_pose, k_global).depth, g_pose,
                            jnp.ones((B,), bool))
        cx, cy = cfg.workspace.center
        first = jnp.broadcast_to(jnp.array([cx, cy, cfg.workspace.table_z + m.start_height], jnp.float32), (B, 3))
        walk = _Walk(grid=grid, position=first, active=jnp.ones((B,), bool), moves=jnp.ones((B,), jnp.int32),
                     travel=jnp.linalg.norm(first - g_pose[:, :3, 3], axis=1))

        def step(w: _Walk, xs):
            t, k = xs
            image = env.camera_image(state.sim, camera.straight_down_pose(w.position), k)
            grid = self.observe(w.grid, params, image.depth, image.pose, w.active)
            nxt = self.next_position(grid, failures, w.position)
            go = (w.active & (nxt[:, 2] - cfg.workspace.table_z >= m.stop_height - 1e-6)
                  & (t < self.steps - 1))
            out = ViewPath(position=w.position, taken=w.active)
            dist = jnp.linalg.norm(nxt - w.position, axis=1)
            return _Walk(grid=grid, position=jnp.where(go[:, None], nxt, w.position), active=go,
                         moves=w.moves + go.astype(jnp.int32), travel=w.travel + jnp.where(go, dist, 0.0)), out

        ts = jnp.arange(self.steps, dtype=jnp.int32)
        return jax.lax.scan(step, walk, (ts, jax.random.split(k_steps, self.steps)))

    def plan(self, params, key, env: VagsEnv, state: EnvState, failures: jax.Array) -> Attempt:
        return self.attempt(self.views(params, key, env, state, failures)[0], failures)

    def attempt(self, walk: _Walk, failures: jax.Array) -> Attempt:
        """The best fused grasp after the viewing phase, from where the camera stopped."""
        xy, z, yaw, _ = G.best_grasp(walk.grid, failures, self.cfg.workspace)
        position = jnp.concatenate([xy, (z - self.cfg.grasp.depth_below_surface)[:, None]], axis=1)
        return Attempt(position=position, yaw=yaw, start=walk.position, motions=1 + walk.moves,
                       view_travel=walk.travel)


__all__ = ["MvpPlanner", "ViewPath"]
