"""Ground-truth top-down heightmaps: what a perfect overhead sensor would give.

An oracle for measuring headroom (bench/gate_headroom.py, bench/viewpoint_states.py): no
viewpoint policy can show GDNet more than this.  A noiseless pinhole camera ``ALTITUDE`` metres
above the workspace centre looks straight down with one image pixel per heightmap cell, each ray
through a cell centre; from that far the rays are parallel to within 4.5 mrad, so every cell
gets the height of the highest surface above its centre (under 0.5 mm of sideways error at 10 cm
of object height) and nothing is occluded except by what is above it.  Rendered with the pure-JAX ray caster
(any device), coloured like the global view (``render.shade``).
"""
from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp

from vags_jax.perception import camera, heightmap, render
from vags_jax.config import Camera, Config

ALTITUDE = 50.0  # m above the table


def topdown_camera(cfg: Config) -> Camera:
    """The overhead camera: H x H pixels, pixel (v, u) looking at the centre of cell (row, col)
    with ``row = H - 1 - v`` (image rows run along world -y), noise off."""
    H, size = cfg.workspace.heightmap_px, cfg.workspace.size
    f = H * ALTITUDE / size
    return dataclasses.replace(cfg.camera, width=H, height=H, fx=f, fy=f, cx=(H - 1) / 2.0, cy=(H - 1) / 2.0,
                               far=ALTITUDE + 1.0,
                               noise=dataclasses.replace(cfg.camera.noise, enabled=False), renderer="jax")


def topdown_pose(cfg: Config) -> jax.Array:
    """(4, 4) the overhead camera's pose, straight down above the workspace centre."""
    cx, cy = cfg.workspace.center
    return camera.straight_down_pose(jnp.array([cx, cy, cfg.workspace.table_z + ALTITUDE], jnp.float32))


class TopDown:
    """Ground-truth maps of an environment's worlds: ``maps(sim_state) -> (color (B, H, W, 3)
    uint8, height (B, H, W) float32)``, jittable, in render batches like the global view."""

    def __init__(self, env):
        self.env, self.cfg = env, env.cfg
        self.cam = topdown_camera(env.cfg)
        self.geometry = render.prepare_geometry(env.scene.mj_model, env.scene.render_geom_mask, backend="jax")

    def maps(self, sim_state):
        cfg, cam = self.cfg, self.cam
        B = sim_state.n_worlds
        pose = jnp.broadcast_to(topdown_pose(cfg), (B, 4, 4))
        size = self.env.sim.geom_size(sim_state)
        sized = size is not None
        d = sim_state.data

        def one_batch(xpos, xmat, rgb, p, sz):
            depth, gid, cos = render.depth_and_segmentation(self.geometry, xpos, xmat, p, cam,
                                                            geom_size=sz if sized else None)
            height, source = heightmap.height_and_source(depth, p, cam, cfg.workspace)
            b = depth.shape[0]
            colour = render.shade(gid.reshape(b, -1), cos.reshape(b, -1), rgb).reshape(depth.shape + (3,))
            return heightmap.gather_at_source(colour, source), height

        args = (d.geom_xpos, d.geom_xmat, sim_state.geom_rgb, pose, size if sized else jnp.zeros((B,), jnp.float32))
        return self.env._per_render_batch(one_batch, args, B)


__all__ = ["ALTITUDE", "topdown_camera", "topdown_pose", "TopDown"]
