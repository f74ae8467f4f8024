"""RGB-D images -> top-down colour and height heightmaps (VPG style, highest point wins).

Each depth pixel is back-projected (pinhole, `vags_jax.perception.camera`), moved to the world frame with
the camera pose and dropped into the heightmap cell under it (row = +y, col = +x, 2 mm cells
at the defaults).  Per cell the highest point wins, colour included.  Heights are metres above
``Workspace.table_z`` clamped at >= 0; cells no point falls in stay 0 with black colour, so
occlusion shadows stay visible.  Points outside the workspace square or with depth 0 (missing)
are dropped.

`heightmaps` is the batched, jit-compiled entry point for simulation; `heightmap_from_frame`
takes one real camera frame (numpy), validates it and returns numpy heightmaps.
"""
from __future__ import annotations

import functools
import warnings

import jax
import jax.numpy as jnp
import numpy as np

from vags_jax.perception import camera as cam_lib
from vags_jax.config import Camera, Workspace


def point_cells(depth, cam_pose, cam_cfg: Camera, ws_cfg: Workspace):
    """Where each depth pixel lands: (flat (B*h*w,) int32 cell index in one index space over the
    batch, B*H*W (one past the last cell, dropped by the scatters) for missing and
    out-of-workspace points; height (B*h*w,) float32 m above the table, >= 0; valid (B, h*w) bool)."""
    b = depth.shape[0]
    n_hm = ws_cfg.heightmap_px
    cells = n_hm * n_hm
    pts = cam_lib.backproject(depth, cam_cfg, cam_pose).reshape(b, -1, 3)  # (B, N, 3) world
    rc = cam_lib.world_xy_to_pixel(pts[..., :2], ws_cfg)  # (B, N, 2) [row, col]
    valid = (depth.reshape(b, -1) > 0) & cam_lib.in_workspace(rc, ws_cfg)
    height = jnp.maximum(pts[..., 2] - ws_cfg.table_z, 0.0)
    flat = jnp.arange(b)[:, None] * cells + rc[..., 0] * n_hm + rc[..., 1]
    return jnp.where(valid, flat, b * cells).reshape(-1), height.reshape(-1), valid


def height_and_source(depth, cam_pose, cam_cfg: Camera, ws_cfg: Workspace):
    """Height heightmaps of B depth images and, per cell, the pixel whose point won it.

    Args: depth (B, h, w), cam_pose (B, 4, 4) as in `heightmaps`.
    Returns:
      height (B, H, W) float32 m above the table (the highest point per cell, 0 where none);
      source (B, H, W) int32 index ``row * w + col`` of the pixel (in the same world's image)
      whose point won the cell (the largest index among equally high points), -1 where none.
    """
    b, h, w = depth.shape
    if b * h * w >= 2**31:
        most = (2**31 - 1) // (h * w)
        fix = (f"pass fewer images per call (at most {most}: camera.render_batch)" if most else
               "even one image is too large: use a smaller image")
        raise ValueError(f"heightmaps of {b} images of {h} x {w} pixels at once overflow int32 pixel indices; {fix}")
    n_hm = ws_cfg.heightmap_px
    cells = b * n_hm * n_hm
    flat, height, valid = point_cells(depth, cam_pose, cam_cfg, ws_cfg)
    # Points with no cell carry index `cells`, out of range: mode="drop" skips them instead of
    # piling every one of them onto a shared dump cell.
    hmax = jnp.zeros(cells, jnp.float32).at[flat].max(height, mode="drop")
    top = valid.reshape(-1) & (height >= hmax.at[flat].get(mode="fill", fill_value=jnp.inf))
    point = jnp.arange(height.shape[0], dtype=jnp.int32)
    source = jnp.full(cells, -1, jnp.int32).at[jnp.where(top, flat, cells)].max(point, mode="drop")
    source = source.reshape(b, -1)
    source = jnp.where(source >= 0, source - jnp.arange(b, dtype=jnp.int32)[:, None] * (h * w), -1)
    return hmax.reshape(b, n_hm, n_hm), source.reshape(b, n_hm, n_hm)


def gather_at_source(values, source):
    """Per-pixel values (B, h, w, ...) -> (B, H, W, ...) at each cell's source pixel, zero in
    empty cells.  ``source`` (B, H, W) is from `height_and_source`."""
    b = values.shape[0]
    flat = values.reshape((b, -1) + values.shape[3:])
    idx = jnp.maximum(source.reshape(b, -1), 0)
    got = jnp.take_along_axis(flat, idx.reshape(idx.shape + (1,) * (flat.ndim - 2)), axis=1)
    got = got.reshape(source.shape + values.shape[3:])
    empty = (source < 0).reshape(source.shape + (1,) * (values.ndim - 3))
    return jnp.where(empty, jnp.zeros((), values.dtype), got)


@functools.partial(jax.jit, static_argnames=("cam_cfg", "ws_cfg"))
def heightmaps(depth, rgb, cam_pose, cam_cfg: Camera, ws_cfg: Workspace):
    """Colour and height heightmaps of B RGB-D images.

    Args:
      depth: (B, h, w) float32 z-depth in metres, 0 = missing.
      rgb: (B, h, w, 3) uint8.
      cam_pose: (B, 4, 4) camera-to-world poses.
      cam_cfg: intrinsics (h, w must match the images); ws_cfg: workspace and grid (static).
    Returns:
      color_hm (B, H, W, 3) uint8 and height_hm (B, H, W) float32, H = W = ws_cfg.heightmap_px.
    """
    depth = jnp.asarray(depth, jnp.float32)
    if depth.shape[1:] != (cam_cfg.height, cam_cfg.width):
        raise ValueError(
            f"depth images have shape {depth.shape[1:]} but the camera config is "
            f"{cam_cfg.height} x {cam_cfg.width} (height x width)"
        )
    height, source = height_and_source(depth, jnp.asarray(cam_pose, jnp.float32), cam_cfg, ws_cfg)
    return gather_at_source(jnp.asarray(rgb, jnp.uint8), source), height


class FrameWarning(UserWarning):
    """A real frame that is valid but unlikely to give a useful heightmap (too little valid
    depth, nothing inside the workspace, points below the table); the message names the likely
    mistake.  Turn into errors with ``warnings.simplefilter("error", FrameWarning)``."""


# Real-frame plausibility limits (heightmap_from_frame).
MAX_POSE_TRANSLATION = 10.0  # m from the robot origin; more suggests millimetres
MIN_VALID_DEPTH = 0.01  # share of pixels with depth > 0
BELOW_TABLE_TOLERANCE = 0.02  # m; points inside the workspace further below the table are wrong
MAX_BELOW_TABLE = 0.25  # share of in-workspace points allowed that far below the table


def check_frame_pose(cam_pose: np.ndarray, ws_cfg: Workspace) -> None:
    """Pose plausibility for a real frame: metres, above the table, looking down.  ``cam_pose``
    (4, 4) is an already-checked rigid transform.  Raises ValueError naming the likely mistake."""
    t = cam_pose[:3, 3].astype(np.float64)
    axis = cam_pose[:3, 2].astype(np.float64)  # the optical axis (camera +z) in the world
    dist = float(np.linalg.norm(t))
    if dist > MAX_POSE_TRANSLATION:
        raise ValueError(
            f"cam_pose puts the camera {dist:.4g} m from the robot origin (translation "
            f"{np.round(t, 3).tolist()}), more than {MAX_POSE_TRANSLATION:g} m: the translation looks "
            f"like millimetres; divide cam_pose[:3, 3] by 1000 to give metres"
        )
    if t[2] <= ws_cfg.table_z:
        raise ValueError(
            f"cam_pose puts the camera at z = {t[2]:.4g} m, at or below the table top "
            f"(workspace.table_z = {ws_cfg.table_z:g}): it cannot see the table. Is it the world-to-camera "
            f"transform (extrinsics)? Pass its inverse, np.linalg.inv(cam_pose), the camera-to-world pose"
        )
    if axis[2] >= 0:
        raise ValueError(
            f"cam_pose's optical axis (camera +z in the world, cam_pose[:3, 2] = "
            f"{np.round(axis, 3).tolist()}) does not point down at the table (its z-component must be "
            f"< 0). Is it the world-to-camera transform (pass np.linalg.inv(cam_pose)), or a pose in "
            f"the OpenGL convention (camera looking along -z; convert with cam_pose @ diag(1, -1, -1, 1))?"
        )


def check_frame_points(depth: np.ndarray, cam_pose: np.ndarray, cam_cfg: Camera, ws_cfg: Workspace) -> None:
    """Warns (``FrameWarning``) when a real frame has too little valid depth, no point inside
    the workspace, or many workspace points below the table.  depth (h, w) metres, 0 = missing."""
    valid = depth > 0
    share = float(valid.mean())
    if share < MIN_VALID_DEPTH:
        warnings.warn(FrameWarning(
            f"only {100 * share:.2g} % of the depth pixels are valid (> 0 and finite), fewer than "
            f"{100 * MIN_VALID_DEPTH:g} %: the heightmap will be (nearly) empty. Check the depth stream "
            f"(is the sensor in range, the image registered, the right channel passed?)"), stacklevel=3)
        return
    # World coordinates per pixel, axis by axis, in float32: p = z R [(u - cx) / fx, (v - cy) / fy, 1]
    # + t (a few whole-image operations: milliseconds for a 640 x 480 frame).
    cx, cy = cam_cfg.principal_point
    h, w = depth.shape
    u = ((np.arange(w) - cx) / cam_cfg.fx)[None, :]
    v = ((np.arange(h) - cy) / cam_cfg.fy)[:, None]
    rot, t = cam_pose[:3, :3].astype(np.float64), cam_pose[:3, 3].astype(np.float64)
    z = depth.astype(np.float32)

    def world(k, where=None):  # coordinate k of every pixel's point (of the pixels ``where``)
        d = ((rot[k, 0] * u + rot[k, 2]).astype(np.float32) + (rot[k, 1] * v).astype(np.float32))
        return z * d + np.float32(t[k]) if where is None else z[where] * d[where] + np.float32(t[k])

    x, y = world(0), world(1)
    xmin, xmax, ymin, ymax = ws_cfg.bounds
    inside = valid & (x >= xmin) & (x < xmax) & (y >= ymin) & (y < ymax)
    if not inside.any():
        c = [float(x[valid].mean()), float(y[valid].mean()), float(world(2, valid).mean())]
        warnings.warn(FrameWarning(
            f"none of the {int(valid.sum())} valid depth points falls inside the workspace square "
            f"x in [{xmin:.3g}, {xmax:.3g}), y in [{ymin:.3g}, {ymax:.3g}) (their mean is at "
            f"{np.round(c, 3).tolist()}): the heightmap will be empty. Check cam_pose (camera-to-world, "
            f"metres, in the robot frame) and workspace.center / workspace.size"), stacklevel=3)
        return
    below = float((world(2, inside) < ws_cfg.table_z - BELOW_TABLE_TOLERANCE).mean())
    if below > MAX_BELOW_TABLE:
        warnings.warn(FrameWarning(
            f"{100 * below:.0f} % of the depth points inside the workspace lie more than "
            f"{100 * BELOW_TABLE_TOLERANCE:g} cm below the table top (workspace.table_z = "
            f"{ws_cfg.table_z:g}): the pose is probably wrong (world-to-camera given instead of "
            f"camera-to-world? another camera convention?), or workspace.table_z is"), stacklevel=3)


def check_frame(depth, rgb, cam_pose, cam_cfg: Camera, ws_cfg: Workspace):
    """The checks of `heightmap_from_frame` on ONE real RGB-D frame, without projecting it ->
    ``(depth (h, w) float32 metres, 0 = missing; rgb (h, w, 3) uint8; cam_pose (4, 4) float32)``.
    Raises ValueError and warns (``FrameWarning``) as `heightmap_from_frame` says."""
    depth = np.asarray(depth)
    rgb = np.asarray(rgb)
    cam_pose = np.asarray(cam_pose)
    want = (cam_cfg.height, cam_cfg.width)
    if depth.ndim == 3 and depth.shape[-1] == 1:
        depth = depth[..., 0]
    if depth.ndim != 2:
        raise ValueError(f"depth must be a 2-D (height, width) image, got shape {depth.shape}")
    if depth.shape != want:
        raise ValueError(
            f"depth has shape {depth.shape} but the camera config expects {want} "
            "(height, width); resize the image or pass a Camera config with matching "
            "width/height/fx/fy/cx/cy"
        )
    if not np.issubdtype(depth.dtype, np.floating):
        raise ValueError(
            f"depth must be floating point metres, got dtype {depth.dtype}; for a uint16 "
            "sensor image in millimetres pass depth.astype(np.float32) / 1000"
        )
    if rgb.shape != want + (3,):
        raise ValueError(f"rgb must have shape {want + (3,)} (height, width, 3), got {rgb.shape}")
    if rgb.dtype != np.uint8:
        raise ValueError(
            f"rgb must be uint8 in 0..255, got dtype {rgb.dtype}; for floats in [0, 1] pass "
            "(rgb * 255).round().astype(np.uint8)"
        )
    if not (np.issubdtype(cam_pose.dtype, np.floating) or np.issubdtype(cam_pose.dtype, np.integer)):
        raise ValueError(f"cam_pose must be a numeric (4, 4) camera-to-world transform, got dtype {cam_pose.dtype}")
    if cam_pose.shape != (4, 4):
        raise ValueError(f"cam_pose must be a (4, 4) camera-to-world transform, got shape {cam_pose.shape}")
    if not np.all(np.isfinite(cam_pose)):
        bad = [f"[{i}, {j}] = {cam_pose[i, j]}" for i, j in zip(*np.nonzero(~np.isfinite(cam_pose)))]
        raise ValueError(f"cam_pose must be finite, but it holds NaN or inf at {', '.join(bad[:4])}"
                         + (f" and {len(bad) - 4} more" if len(bad) > 4 else ""))
    rot = cam_pose[:3, :3].astype(np.float64)
    if not np.allclose(rot.T @ rot, np.eye(3), atol=1e-4) or np.linalg.det(rot) < 0 or not np.allclose(
        cam_pose[3], [0, 0, 0, 1], atol=1e-6
    ):
        raise ValueError("cam_pose must be a rigid transform: orthonormal rotation (det +1), last row [0, 0, 0, 1]")
    check_frame_pose(cam_pose, ws_cfg)
    depth = np.where(np.isfinite(depth), depth, 0.0).astype(np.float32)
    if np.any(depth < 0):
        raise ValueError(f"depth has negative values (min {depth.min():.4g}); missing pixels must be 0 or NaN")
    if depth.max(initial=0.0) > 10.0:
        raise ValueError(
            f"depth values reach {depth.max():.4g}, more than 10 m: the image looks like "
            "millimetres; divide by 1000 to give metres"
        )
    check_frame_points(depth, cam_pose, cam_cfg, ws_cfg)
    return depth, rgb, cam_pose.astype(np.float32)


def heightmap_from_frame(depth, rgb, cam_pose, cam_cfg: Camera, ws_cfg: Workspace):
    """Heightmaps of ONE real RGB-D frame, with input validation (numpy in, numpy out).

    Args:
      depth: (h, w) float depth in metres (z along the optical axis); 0, NaN and inf are
        treated as missing.  (h, w) must equal (cam_cfg.height, cam_cfg.width).
      rgb: (h, w, 3) uint8 colour image registered to the depth image.
      cam_pose: (4, 4) camera-to-world transform (OpenCV camera frame) in the robot frame.
    Returns:
      color_hm (H, W, 3) uint8 and height_hm (H, W) float32.
    Raises:
      ValueError with a hint for wrong shapes, dtypes, millimetre depth, negative depth, a pose
      that is not a rigid transform, a pose in millimetres (more than 10 m from the origin), a
      camera at or below the table or one not looking down (a world-to-camera pose, or the
      OpenGL convention).
    Warns:
      FrameWarning when under 1 % of the pixels have depth, no point falls inside the
      workspace, or over a quarter of the workspace points lie 2 cm or more below the table.
      All checks run before anything is compiled.
    """
    depth, rgb, cam_pose = check_frame(depth, rgb, cam_pose, cam_cfg, ws_cfg)
    color, height = heightmaps(depth[None], rgb[None], cam_pose[None], cam_cfg, ws_cfg)
    return np.asarray(color[0]), np.asarray(height[0])
