"""A close depth image fused into the global heightmaps (the "gdnet" close-view planner).

The camera moved to a viewpoint sees the cells under it from straight above, at about a third
of the global view's distance: fewer occlusion shadows and finer depth.  ``close_heightmaps``
projects a close RGB-D image at its pose into the workspace grid exactly as the global view is
projected (``heightmap.height_and_source``: highest point per cell); ``fuse`` keeps the close
view's height and colour wherever it put a point and the global view's elsewhere.  GDNet then
runs on the fused maps like on any global view.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp

from vags_jax.perception import heightmap
from vags_jax.config import Camera, Workspace


def close_heightmaps(depth: jax.Array, rgb: jax.Array, pose: jax.Array, cam_cfg: Camera, ws_cfg: Workspace):
    """Close RGB-D images -> their heightmaps and the cells they saw.

    depth (B, h, w) float32 metres (0 = missing), rgb (B, h, w, 3) uint8, pose (B, 4, 4)
    camera-to-world.  Returns color (B, H, W, 3) uint8, height (B, H, W) float32 metres above
    the table, seen (B, H, W) bool: a point of the image fell in the cell.
    """
    height, source = heightmap.height_and_source(depth, pose, cam_cfg, ws_cfg)
    color = heightmap.gather_at_source(rgb, source)
    return color, height, source >= 0


def fuse(color: jax.Array, height: jax.Array, close_color: jax.Array, close_height: jax.Array,
         seen: jax.Array):
    """Global maps (B, H, W, 3) uint8 / (B, H, W) with the close view's maps where ``seen``
    (B, H, W) -> fused (color (B, H, W, 3) uint8, height (B, H, W) float32)."""
    fused_h = jnp.where(seen, close_height, height).astype(jnp.float32)
    fused_c = jnp.where(seen[..., None], close_color, color).astype(jnp.uint8)
    return fused_c, fused_h


def fuse_close_view(color: jax.Array, height: jax.Array, depth: jax.Array, rgb: jax.Array, pose: jax.Array,
                    cam_cfg: Camera, ws_cfg: Workspace):
    """``close_heightmaps`` then ``fuse`` -> (color (B, H, W, 3), height (B, H, W), seen (B, H, W))."""
    c_col, c_h, seen = close_heightmaps(depth, rgb, pose, cam_cfg, ws_cfg)
    f_col, f_h = fuse(color, height, c_col, c_h, seen)
    return f_col, f_h, seen


__all__ = ["close_heightmaps", "fuse", "fuse_close_view"]
