"""Observing B worlds: the eye-in-hand camera's RGB-D image (with the sensor model) and the
heightmaps made from it, rendered in groups of ``camera.render_batch`` worlds (the
``VagsEnv``'s ``Observation`` part; it uses the env's ``cfg``, ``scene``, ``sim``, ``global_pose``)."""
from __future__ import annotations

from typing import Optional

import jax
import jax.numpy as jnp
from flax import struct

from vags_jax import batching
from vags_jax.perception import heightmap, render
from vags_jax.sim.simulator import SimState


@struct.dataclass
class CameraImage:
    """Raw RGB-D images of B worlds: depth (B, h, w) float32 metres along the optical axis (sensor
    model applied, 0 = missing); rgb (B, h, w, 3) uint8; pose (B, 4, 4) camera-to-world."""

    depth: jax.Array
    rgb: jax.Array
    pose: jax.Array



class Observation:
    """Rendering and heightmaps of a ``VagsEnv``."""

    def prepare(self, n_worlds: int) -> None:
        """Build the render geometry for ``n_worlds`` eagerly (the Warp renderer's context is
        per batch size).  Call it before tracing a function that uses the ``step_*`` methods
        (the public methods and ``stages`` do)."""
        self.geometry(min(n_worlds, self.cfg.camera.render_batch))

    def geometry(self, n_worlds: int):
        """Static render geometry (the Warp renderer's context is per batch size)."""
        key = n_worlds if self.cfg.camera.renderer == "warp" else 0
        if key not in self._geometry:
            with jax.ensure_compile_time_eval():  # built eagerly even when first asked inside jit
                self._geometry[key] = render.prepare_geometry(
                    self.scene.mj_model, self.scene.render_geom_mask, backend=self.cfg.camera.renderer,
                    cam_cfg=self.cfg.camera, n_worlds=n_worlds,
                )
        return self._geometry[key]

    def _per_render_batch(self, fn, args: tuple, B: int):
        """``fn(*args)`` over B worlds in groups of ``camera.render_batch`` (memory stays that of
        one group; the Warp renderer's context is built for that many worlds).  Every leaf of
        ``args`` and of the output has the leading world axis B."""
        return batching.map_in_groups(fn, tuple(args), self.cfg.camera.render_batch)

    def _sensor(self, sim_state: SimState, cam_pose: jax.Array, key: Optional[jax.Array]):
        """What ``fn(xpos, xmat, rgb, pose, keys, size)`` needs to render B worlds: the render
        geometry, a function giving ``(sensor depth (b,h,w), clean depth, geom id, cos)`` for a
        group of worlds, and the per-world argument tuple."""
        cfg = self.cfg
        B = sim_state.n_worlds
        d = sim_state.data
        if cfg.camera.noise.enabled and key is None:
            raise ValueError("camera.noise.enabled needs a PRNG key to render a sensor image")
        keys = jax.random.split(key if key is not None else jax.random.PRNGKey(0), B)
        geometry = self.geometry(min(B, cfg.camera.render_batch))
        size = self.sim.geom_size(sim_state)  # (B, ngeom, 3), or None: no size is drawn
        sized = size is not None

        def sense(xpos, xmat, pose, k, size):
            clean, gid, cos = render.depth_and_segmentation(geometry, xpos, xmat, pose, cfg.camera,
                                                            geom_size=size if sized else None)
            depth = clean
            if cfg.camera.noise.enabled:
                if cos is None:
                    cos = render.normals_from_depth(clean, cfg.camera, gid)
                depth = jax.vmap(lambda kk, dd, cc: render.add_depth_noise(
                    kk, dd[None], cc[None], cfg.camera.noise, cfg.camera.fx)[0])(k, depth, cos)
            return depth, clean, gid, cos

        args = (d.geom_xpos, d.geom_xmat, sim_state.geom_rgb, cam_pose, keys,
                size if sized else jnp.zeros((B,), jnp.float32))
        return sense, args

    def observe(self, sim_state: SimState, cam_pose: jax.Array, key: Optional[jax.Array] = None):
        """Render every world from cam_pose (B, 4, 4) -> (color (B,H,W,3) uint8, height (B,H,W)).

        ``key`` is needed only when the config's depth noise is enabled.
        """
        cfg = self.cfg
        sense, args = self._sensor(sim_state, cam_pose, key)

        def one_batch(xpos, xmat, rgb, pose, k, size):
            depth, clean, gid, cos = sense(xpos, xmat, pose, k, size)
            height, source = heightmap.height_and_source(depth, pose, cfg.camera, cfg.workspace)
            # Colour only where the heightmap uses it, at each cell's source pixel: the same
            # shading as `render.render_full`, without colouring the whole image first.
            b = depth.shape[0]
            pix = jnp.maximum(source.reshape(b, -1), 0)
            g = jnp.where(source.reshape(b, -1) >= 0, jnp.take_along_axis(gid.reshape(b, -1), pix, axis=1), -1)
            c = (jnp.take_along_axis(cos.reshape(b, -1), pix, axis=1) if cos is not None
                 else render.cos_incidence_at(clean, pix, cfg.camera, gid))
            color = render.shade(g, c, rgb).reshape(height.shape + (3,))
            return color, height

        return self._per_render_batch(one_batch, args, sim_state.n_worlds)

    def camera_image(self, sim_state: SimState, cam_pose: jax.Array, key: Optional[jax.Array] = None):
        """The raw RGB-D image of every world from cam_pose (B, 4, 4), as the eye-in-hand
        camera delivers it -> ``CameraImage`` (depth (B, h, w) float32 metres with the sensor
        model's noise and holes, 0 = missing; rgb (B, h, w, 3) uint8; pose (B, 4, 4)).

        ``key`` is needed only when the config's depth noise is enabled.
        """
        cfg = self.cfg
        sense, args = self._sensor(sim_state, cam_pose, key)

        def one_batch(xpos, xmat, rgb, pose, k, size):
            depth, clean, gid, cos = sense(xpos, xmat, pose, k, size)
            if cos is None:
                cos = render.normals_from_depth(clean, cfg.camera, gid)
            b, h, w = depth.shape
            color = render.shade(gid.reshape(b, -1), cos.reshape(b, -1), rgb).reshape(b, h, w, 3)
            return depth, color

        depth, rgb = self._per_render_batch(one_batch, args, sim_state.n_worlds)
        return CameraImage(depth=depth, rgb=rgb, pose=cam_pose)

    def observe_global(self, sim_state: SimState, key: Optional[jax.Array] = None):
        pose = jnp.broadcast_to(jnp.asarray(self.global_pose), (sim_state.n_worlds, 4, 4))
        return self.observe(sim_state, pose, key)
