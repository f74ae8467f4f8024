"""Pinhole camera geometry: intrinsics, poses, projection and heightmap-cell <-> world maps.

Conventions (see ``vags_jax.config``): OpenCV camera frame (x right, y down, z forward along
the optical axis); a pose is a ``(4, 4)`` camera-to-world transform; pixel ``(u, v)`` =
``(col, row)`` of an image samples the ray through ``((u - cx) / fx, (v - cy) / fy, 1)`` in
the camera frame; depth is the z-distance along the optical axis.  Heightmap cell
``(row, col)`` has its centre at ``x = xmin + (col + 0.5) * px``, ``y = ymin + (row + 0.5) * px``.

Every function is pure ``jnp`` code: jit-able, and batched over any leading axes ``...``.
"""
from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from vags_jax.config import Camera, Workspace

# Rotation (camera-to-world) of a camera looking straight down (-z world).  Its image columns
# (u, camera x) run along world +x and its image rows (v, camera y) along world -y, so the top
# of the image is the +y side of the scene.  (A right-handed camera looking down cannot have
# rows along +y *and* columns along +x: the image is the heightmap flipped upside down.)
DOWN_ROTATION = np.diag([1.0, -1.0, -1.0])


def intrinsics(cam_cfg: Camera) -> jnp.ndarray:
    """The (3, 3) pinhole matrix K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]."""
    cx, cy = cam_cfg.principal_point
    return jnp.array([[cam_cfg.fx, 0.0, cx], [0.0, cam_cfg.fy, cy], [0.0, 0.0, 1.0]], jnp.float32)


def make_pose(rotation, position) -> jnp.ndarray:
    """(..., 3, 3) rotation and (..., 3) position -> (..., 4, 4) homogeneous transform."""
    rotation = jnp.asarray(rotation, jnp.float32)
    position = jnp.asarray(position, jnp.float32)
    batch = jnp.broadcast_shapes(rotation.shape[:-2], position.shape[:-1])
    top = jnp.concatenate(
        [jnp.broadcast_to(rotation, batch + (3, 3)), jnp.broadcast_to(position, batch + (3,))[..., None]],
        axis=-1,
    )
    bottom = jnp.broadcast_to(jnp.array([0.0, 0.0, 0.0, 1.0], jnp.float32), batch + (1, 4))
    return jnp.concatenate([top, bottom], axis=-2)


def look_at(position, target, up=(0.0, 0.0, 1.0)) -> jnp.ndarray:
    """Camera-to-world pose (..., 4, 4) of a camera at `position` (..., 3) looking at `target`.

    The optical axis (camera z) points at the target; camera y ("down" in the image) points
    away from `up` projected onto the image plane.  `up` must not be parallel to the view
    direction (use `straight_down_pose` for that).
    """
    position = jnp.asarray(position, jnp.float32)
    target = jnp.asarray(target, jnp.float32)
    up = jnp.asarray(up, jnp.float32)
    z = target - position
    z = z / jnp.linalg.norm(z, axis=-1, keepdims=True)
    x = jnp.cross(z, jnp.broadcast_to(up, z.shape))
    x = x / jnp.linalg.norm(x, axis=-1, keepdims=True)
    y = jnp.cross(z, x)
    return make_pose(jnp.stack([x, y, z], axis=-1), position)


def straight_down_pose(position) -> jnp.ndarray:
    """(..., 4, 4) pose of a camera at `position` (..., 3) looking straight down.

    Fixed image orientation: image columns run along world +x, image rows along world -y
    (see `DOWN_ROTATION`).
    """
    return make_pose(jnp.asarray(DOWN_ROTATION, jnp.float32), position)


def global_pose(cam_cfg: Camera) -> jnp.ndarray:
    """The preset global camera pose (4, 4) from `global_position` / `global_target`.

    The image's up direction is world +z (so with the default pose, which looks at the
    table from the -y side, the top of the image shows the far, +y edge of the workspace).
    """
    return look_at(cam_cfg.global_position, cam_cfg.global_target, (0.0, 0.0, 1.0))


# ----------------------------------------------------------------------------- heightmap cells


def pixel_to_world_xy(pixel, ws_cfg: Workspace) -> jnp.ndarray:
    """Heightmap cell (..., 2) int [row, col] -> world (..., 2) [x, y] of the cell centre."""
    pixel = jnp.asarray(pixel)
    xmin, _, ymin, _ = ws_cfg.bounds
    px = ws_cfg.pixel_size
    x = xmin + (pixel[..., 1].astype(jnp.float32) + 0.5) * px
    y = ymin + (pixel[..., 0].astype(jnp.float32) + 0.5) * px
    return jnp.stack([x, y], axis=-1)


def world_xy_to_pixel(xy, ws_cfg: Workspace) -> jnp.ndarray:
    """World (..., 2) [x, y] -> heightmap cell (..., 2) int32 [row, col] containing it.

    Not clipped: points outside the workspace give indices outside 0..H-1 (check with
    `in_workspace`).
    """
    xy = jnp.asarray(xy, jnp.float32)
    xmin, _, ymin, _ = ws_cfg.bounds
    px = ws_cfg.pixel_size
    col = jnp.floor((xy[..., 0] - xmin) / px).astype(jnp.int32)
    row = jnp.floor((xy[..., 1] - ymin) / px).astype(jnp.int32)
    return jnp.stack([row, col], axis=-1)


def in_workspace(pixel, ws_cfg: Workspace) -> jnp.ndarray:
    """(..., 2) [row, col] -> (...,) bool, True where the cell is inside the heightmap."""
    n = ws_cfg.heightmap_px
    return jnp.all((pixel >= 0) & (pixel < n), axis=-1)


def viewpoint_pose(pixel, height_map, ws_cfg: Workspace, cam_cfg: Camera) -> jnp.ndarray:
    """Camera pose (..., 4, 4) for a viewpoint chosen at a heightmap cell.

    Args:
      pixel: (..., 2) int [row, col] of the chosen cell (clipped into the heightmap).
      height_map: (..., H, W) heights above the table (metres).
    Returns:
      (..., 4, 4): camera `cam_cfg.viewpoint_height` above the surface at the cell centre,
      i.e. at z = table_z + height_map[row, col] + viewpoint_height, looking straight down
      with the fixed orientation of `straight_down_pose` (image columns = world +x, image
      rows = world -y).
    """
    pixel = jnp.clip(jnp.asarray(pixel, jnp.int32), 0, ws_cfg.heightmap_px - 1)
    height_map = jnp.asarray(height_map, jnp.float32)
    flat = height_map.reshape(height_map.shape[:-2] + (-1,))
    idx = pixel[..., 0] * height_map.shape[-1] + pixel[..., 1]
    h = jnp.take_along_axis(flat, idx[..., None], axis=-1)[..., 0]
    xy = pixel_to_world_xy(pixel, ws_cfg)
    z = ws_cfg.table_z + h + cam_cfg.viewpoint_height
    return straight_down_pose(jnp.concatenate([xy, z[..., None]], axis=-1))


# ----------------------------------------------------------------------------- projection


def pixel_rays(cam_cfg: Camera) -> jnp.ndarray:
    """(h, w, 3) camera-frame ray directions ((u - cx) / fx, (v - cy) / fy, 1) of all pixels.

    A point at depth z along pixel (v, u)'s ray is z * rays[v, u].
    """
    cx, cy = cam_cfg.principal_point
    u = (jnp.arange(cam_cfg.width, dtype=jnp.float32) - cx) / cam_cfg.fx
    v = (jnp.arange(cam_cfg.height, dtype=jnp.float32) - cy) / cam_cfg.fy
    uu, vv = jnp.meshgrid(u, v)
    return jnp.stack([uu, vv, jnp.ones_like(uu)], axis=-1)


def transform_points(pose, points) -> jnp.ndarray:
    """Apply (..., 4, 4) transforms to (..., N, 3) points -> (..., N, 3)."""
    return jnp.einsum("...ij,...nj->...ni", pose[..., :3, :3], points) + pose[..., None, :3, 3]


def invert_pose(pose) -> jnp.ndarray:
    """Inverse of rigid transforms (..., 4, 4)."""
    rot_t = jnp.swapaxes(pose[..., :3, :3], -1, -2)
    return make_pose(rot_t, -jnp.einsum("...ij,...j->...i", rot_t, pose[..., :3, 3]))


def project(points_world, cam_pose, cam_cfg: Camera):
    """World points (..., N, 3) -> (uv (..., N, 2) float [u=col, v=row], z (..., N) depth).

    Points behind the camera get z <= 0 (their uv are meaningless).
    """
    p_cam = transform_points(invert_pose(cam_pose), points_world)
    cx, cy = cam_cfg.principal_point
    z = p_cam[..., 2]
    safe = jnp.where(jnp.abs(z) > 1e-9, z, 1e-9)
    u = cam_cfg.fx * p_cam[..., 0] / safe + cx
    v = cam_cfg.fy * p_cam[..., 1] / safe + cy
    return jnp.stack([u, v], axis=-1), z


def backproject(depth, cam_cfg: Camera, cam_pose=None) -> jnp.ndarray:
    """Depth image (..., h, w) -> points (..., h, w, 3).

    In the camera frame when `cam_pose` is None, else in the world frame via `cam_pose`
    (..., 4, 4).  Pixels with depth 0 map to the camera origin (mask them with depth > 0).
    """
    depth = jnp.asarray(depth, jnp.float32)
    pts = depth[..., None] * pixel_rays(cam_cfg)
    if cam_pose is None:
        return pts
    rot = cam_pose[..., :3, :3]
    return jnp.einsum("...ij,...hwj->...hwi", rot, pts) + cam_pose[..., None, None, :3, 3]
