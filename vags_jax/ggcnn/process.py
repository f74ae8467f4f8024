"""GG-CNN input and output processing: depth -> network input, maps -> best grasp -> world grasp.

Conventions (shared with ``vags_jax.ggcnn.labels`` and ``vags_jax.nets.ggcnn``):

* Images are ``(B, H, W)``; a pixel is ``(u, v) = (column, row)`` as in ``vags_jax.perception.camera``
  (pixel centres at integer coordinates, ``v`` downward).  Pixel arrays are ``(..., 2)``
  ``[u, v]``.
* Depth is metres along the optical axis (``vags_jax.config``).  A pixel is missing where its
  depth is 0, negative, NaN or infinite.
* Grasp angle ``theta`` (radians, in ``(-pi/2, pi/2]``): the gripper's closing axis runs along
  ``(du, dv) = (cos theta, sin theta)`` in the image.  ``theta`` and ``theta + pi`` are the same
  grasp, hence the network predicts cos 2theta and sin 2theta.  (GG-CNN's own code measures the
  angle with the image's v axis flipped, i.e. the opposite sign; we train our own labels, so
  only consistency matters.)
* Width: the network's width map is the gripper opening in *network-input* pixels divided by
  ``GGCNNConfig.width_scale`` (150, as GG-CNN); ``postprocess`` multiplies it back to pixels and
  ``grasp_to_world`` turns pixels into metres with the network-input intrinsics
  (``pixels * depth / fx``).
* Intrinsics are ``(..., 3, 3)`` pinhole matrices ``[[fx, 0, cx], [0, fy, cy], [0, 0, 1]]``
  (``vags_jax.perception.camera.intrinsics``); poses are ``(..., 4, 4)`` camera-to-world transforms in the
  OpenCV convention (x right, y down, z forward).

Pipeline::

    depth_in, K_in = crop_resize(camera_depth, K, cfg)     # (B, 300, 300), (B, 3, 3)
    x, depth_m, valid = preprocess_depth(depth_in, cfg)     # network input, inpainted metres
    maps = GGCNN().apply(params, x)                         # GraspMaps (B, 300, 300)
    g = best_grasp(maps, cfg, valid_depth(depth_in))        # ImageGrasp, (B,) per field
    world = grasp_to_world(g.pixel, g.angle, g.width_px,
                           sample_depth(depth_m, g.pixel), K_in, cam_pose)

Every function is pure JAX and jit-able.  Shape and dtype errors raise ValueError at trace
time; a frame with no valid depth at all raises ValueError when ``preprocess_depth`` is called
outside ``jit`` (inside ``jit`` it cannot raise: such frames come back as zeros with
``valid = False``).
"""
from __future__ import annotations

import math
from typing import Optional

import flax.struct
import jax
import jax.numpy as jnp
from jax import lax

from vags_jax.nets.ggcnn import GGCNNConfig, GraspMaps
from vags_jax.nets.rotation import sample_bilinear


def _check(cond: bool, msg: str) -> None:
    if not cond:
        raise ValueError(msg)


def _is_concrete(x) -> bool:
    return not isinstance(x, jax.core.Tracer)


def check_depth(depth, name: str = "depth") -> None:
    """Raise ValueError unless ``depth`` is a float ``(B, H, W)`` array (metres)."""
    shape = tuple(getattr(depth, "shape", ()))
    dtype = getattr(depth, "dtype", None)
    _check(
        len(shape) == 3 and shape[1] >= 1 and shape[2] >= 1,
        f"{name} must be a (B, H, W) batch of depth images, got shape {shape}; "
        "add a batch axis for a single image",
    )
    _check(
        dtype is not None and jnp.issubdtype(dtype, jnp.floating),
        f"{name} must be float depth in metres, got dtype {dtype}; convert sensor millimetres "
        "(e.g. uint16) with depth.astype(float32) / 1000",
    )


def valid_depth(depth: jax.Array) -> jax.Array:
    """``(B, H, W)`` bool: True where the depth is finite and > 0."""
    return jnp.isfinite(depth) & (depth > 0)


def _box3(x: jax.Array) -> jax.Array:
    """Sum over each pixel's 3 x 3 neighbourhood (zeros outside), ``(B, H, W) -> (B, H, W)``."""
    return lax.reduce_window(x, 0.0, lax.add, (1, 3, 3), (1, 1, 1), ((0, 0), (1, 1), (1, 1)))


def inpaint_depth(depth: jax.Array, iters: int = 64) -> tuple[jax.Array, jax.Array]:
    """Fill missing depth by growing the valid region one pixel ring at a time.

    Each pass gives every missing pixel that touches a known one (3 x 3 neighbourhood) the mean
    of its known neighbours, and marks it known; passes repeat until no hole is left or
    ``iters`` passes were made.  Anything still missing after that (holes wider than about
    ``2 * iters`` pixels) gets the frame's mean valid depth.  Valid pixels never change.

    Args:
      depth: ``(B, H, W)`` float metres; missing = 0 / negative / NaN / inf.
      iters: static cap on the passes.
    Returns:
      ``filled`` ``(B, H, W)`` float32 and ``any_valid`` ``(B,)`` bool.  Frames with no valid
      pixel at all come back as zeros with ``any_valid = False``.
    """
    check_depth(depth)
    mask0 = valid_depth(depth)
    d0 = jnp.where(mask0, depth, 0.0).astype(jnp.float32)
    any_valid = jnp.any(mask0, axis=(1, 2))

    def cond(state):
        _, mask, i = state
        return (i < iters) & jnp.any(~mask & any_valid[:, None, None])

    def body(state):
        d, mask, i = state
        m = mask.astype(jnp.float32)
        total = _box3(d * m)
        count = _box3(m)
        grow = ~mask & (count > 0)
        d = jnp.where(grow, total / jnp.maximum(count, 1.0), d)
        return d, mask | grow, i + 1

    d, mask, _ = lax.while_loop(cond, body, (d0, mask0, jnp.int32(0)))
    n = jnp.sum(mask0, axis=(1, 2))
    mean = jnp.sum(d0, axis=(1, 2)) / jnp.maximum(n, 1)
    d = jnp.where(mask, d, mean[:, None, None])
    return jnp.where(any_valid[:, None, None], d, 0.0), any_valid


def preprocess_depth(depth: jax.Array, cfg: GGCNNConfig = GGCNNConfig()):
    """GG-CNN input from depth images: inpaint, subtract the mean valid depth, clip to [-1, 1].

    Args:
      depth: ``(B, H, W)`` float metres, already at the network resolution (see
        ``crop_resize``); missing pixels as in ``valid_depth``.
    Returns:
      ``(x, filled, any_valid)``: ``x`` ``(B, H, W)`` float32 network input in [-1, 1];
      ``filled`` ``(B, H, W)`` float32 inpainted depth in metres (for ``sample_depth``);
      ``any_valid`` ``(B,)`` bool.
    Raises:
      ValueError: wrong shape / dtype; or, called outside ``jit``, a frame without any valid
      depth (inside ``jit`` such a frame gives ``x = 0`` and ``any_valid = False``).
    """
    check_depth(depth)
    if _is_concrete(depth):
        bad = ~jnp.any(valid_depth(jnp.asarray(depth)), axis=(1, 2))
        if bool(jnp.any(bad)):
            frames = [int(i) for i in jnp.nonzero(bad)[0]]
            raise ValueError(
                f"depth frame(s) {frames} have no valid pixel (all 0 / NaN / inf): "
                "nothing to inpaint from; check the camera or drop those frames"
            )
    filled, any_valid = inpaint_depth(depth, cfg.inpaint_iters)
    mask0 = valid_depth(depth)
    n = jnp.sum(mask0, axis=(1, 2))
    mean = jnp.sum(jnp.where(mask0, depth, 0.0), axis=(1, 2)) / jnp.maximum(n, 1)
    x = jnp.clip(filled - mean[:, None, None], -1.0, 1.0)
    x = jnp.where(any_valid[:, None, None], x, 0.0).astype(jnp.float32)
    return x, filled, any_valid


def crop_resize(depth: jax.Array, intrinsics: jax.Array, cfg: GGCNNConfig = GGCNNConfig()):
    """Centred square crop of camera depth images, resized to ``cfg.input_size``.

    The crop is ``cfg.crop_size`` camera pixels (None: ``min(H, W)``) around the image centre,
    starting at row ``(H - crop) // 2`` and column ``(W - crop) // 2``.  Resizing is bilinear over
    valid pixels only (a normalised convolution: missing pixels carry no weight, so holes do not
    pull depths towards 0); an output pixel with no valid source stays missing (0).  Output
    pixel ``i`` samples the crop at ``(i + 0.5) * s - 0.5`` with ``s = crop / input_size``, so
    the intrinsics become ``fx' = fx / s``, ``fy' = fy / s``, ``cx' = (cx - c0 + 0.5) / s - 0.5``
    and ``cy' = (cy - r0 + 0.5) / s - 0.5``.

    Args:
      depth: ``(B, H, W)`` float metres.
      intrinsics: ``(3, 3)`` or ``(B, 3, 3)`` of the camera image.
    Returns:
      ``(depth_out (B, S, S) float32, intrinsics_out (B, 3, 3) float32)``, ``S = cfg.input_size``.
    """
    check_depth(depth)
    b, h, w = depth.shape
    k = jnp.asarray(intrinsics, jnp.float32)
    _check(k.shape in ((3, 3), (b, 3, 3)),
           f"crop_resize: intrinsics must be (3, 3) or (B, 3, 3) = ({b}, 3, 3), got {k.shape}")
    crop = min(h, w) if cfg.crop_size is None else cfg.crop_size
    _check(crop <= min(h, w),
           f"GGCNNConfig.crop_size = {crop} exceeds the depth image ({h} x {w}); use at most {min(h, w)}")
    r0, c0 = (h - crop) // 2, (w - crop) // 2
    size = cfg.input_size
    s = crop / size
    coords = (jnp.arange(size, dtype=jnp.float32) + 0.5) * s - 0.5
    rows = jnp.broadcast_to(r0 + coords[:, None], (size, size))
    cols = jnp.broadcast_to(c0 + coords[None, :], (size, size))
    mask = valid_depth(depth)
    stacked = jnp.stack([jnp.where(mask, depth, 0.0), mask.astype(jnp.float32)], axis=-1)
    sampled = jax.vmap(lambda im: sample_bilinear(im, rows, cols, "clamp"))(stacked)
    weight = sampled[..., 1]
    out = jnp.where(weight > 1e-6, sampled[..., 0] / jnp.maximum(weight, 1e-6), 0.0)
    k = jnp.broadcast_to(k, (b, 3, 3))
    fx, fy = k[:, 0, 0] / s, k[:, 1, 1] / s
    cx = (k[:, 0, 2] - c0 + 0.5) / s - 0.5
    cy = (k[:, 1, 2] - r0 + 0.5) / s - 0.5
    zero, one = jnp.zeros_like(fx), jnp.ones_like(fx)
    k_out = jnp.stack([
        jnp.stack([fx, zero, cx], -1), jnp.stack([zero, fy, cy], -1), jnp.stack([zero, zero, one], -1),
    ], axis=-2)
    return out.astype(jnp.float32), k_out


# ----------------------------------------------------------------------------- post-processing


def gaussian_kernel(sigma: float) -> jax.Array:
    """Normalised 1-D Gaussian taps, radius ``int(4 sigma + 0.5)`` (scipy.ndimage's default)."""
    radius = int(4.0 * sigma + 0.5)
    x = jnp.arange(-radius, radius + 1, dtype=jnp.float32)
    k = jnp.exp(-0.5 * (x / sigma) ** 2)
    return k / jnp.sum(k)


def gaussian_blur(x: jax.Array, sigma: float) -> jax.Array:
    """Separable Gaussian filter of ``(B, H, W)`` maps; borders mirrored (scipy's "reflect").

    ``sigma`` is static; ``sigma == 0`` returns ``x`` unchanged.
    """
    if sigma <= 0:
        return x
    k = gaussian_kernel(sigma)
    r = (k.shape[0] - 1) // 2
    y = jnp.pad(x.astype(jnp.float32), ((0, 0), (r, r), (r, r)), mode="symmetric")[..., None]
    dn = ("NHWC", "HWIO", "NHWC")
    y = lax.conv_general_dilated(y, k.reshape(-1, 1, 1, 1), (1, 1), "VALID", dimension_numbers=dn)
    y = lax.conv_general_dilated(y, k.reshape(1, -1, 1, 1), (1, 1), "VALID", dimension_numbers=dn)
    return y[..., 0]


@flax.struct.dataclass
class ImageGrasp:
    """The best grasp of each image: ``pixel`` ``(B, 2)`` int32 ``[u, v]``; ``quality``,
    ``angle`` (radians, closing axis, see module docstring) and ``width_px`` (opening in
    network-input pixels), each ``(B,)`` float32."""

    pixel: jax.Array
    quality: jax.Array
    angle: jax.Array
    width_px: jax.Array


def postprocess(maps: GraspMaps, cfg: GGCNNConfig = GGCNNConfig()):
    """Smoothed GG-CNN maps: ``(quality, angle, width_px)``, each ``(B, H, W)`` float32.

    Quality is blurred with ``cfg.quality_sigma``; cos 2theta and sin 2theta with
    ``cfg.angle_sigma`` before ``angle = atan2(sin, cos) / 2`` (GG-CNN blurs the angle map
    itself, which smears across the +-pi/2 wrap; blurring the cos/sin pair does not); width
    with ``cfg.width_sigma``, then ``width_px = width * cfg.width_scale``.  The defaults blur
    only the quality (angle and width sigmas 0): blurring cos / sin mixes a neighbouring
    grasp's angle into the peak's, giving an angle nobody tried.
    """
    quality = gaussian_blur(maps.quality, cfg.quality_sigma)
    cos = gaussian_blur(maps.cos, cfg.angle_sigma)
    sin = gaussian_blur(maps.sin, cfg.angle_sigma)
    width = gaussian_blur(maps.width, cfg.width_sigma)
    return quality, 0.5 * jnp.arctan2(sin, cos), width * cfg.width_scale


def peak(quality: jax.Array) -> jax.Array:
    """Argmax pixel of each ``(B, H, W)`` map -> ``(B, 2)`` int32 ``[u, v]`` (first on ties)."""
    b, h, w = quality.shape
    idx = jnp.argmax(quality.reshape(b, h * w), axis=-1).astype(jnp.int32)
    return jnp.stack([idx % w, idx // w], axis=-1)


def _at(image: jax.Array, pixel: jax.Array) -> jax.Array:
    """``image`` ``(B, H, W)`` read at ``pixel`` ``(B, 2)`` [u, v] -> ``(B,)``."""
    b, h, w = image.shape
    u = jnp.clip(pixel[:, 0], 0, w - 1)
    v = jnp.clip(pixel[:, 1], 0, h - 1)
    return image[jnp.arange(b), v, u]


def sample_depth(depth: jax.Array, pixel: jax.Array) -> jax.Array:
    """Depth ``(B, H, W)`` at integer pixels ``(B, 2)`` [u, v] (clipped into the image) -> ``(B,)``."""
    return _at(depth, jnp.asarray(pixel, jnp.int32))


def peak_score(raw: jax.Array, smoothed: jax.Array, valid: Optional[jax.Array] = None) -> jax.Array:
    """The map whose argmax is the grasp: ``min(raw, smoothed)`` quality, ``(B, H, W)``.

    A pixel must score high itself, not only its neighbourhood: the smoothed peak alone can
    land in the gap between two narrow positives (or on a failure between successes), a grasp
    the maps never held.  ``valid`` ``(B, H, W)`` bool (pixels with raw depth, ``valid_depth``):
    elsewhere the score is -inf, unless an image has no valid pixel at all (then it is kept),
    so the grasp never sits in an inpainted hole, where its depth is invented.
    """
    score = jnp.minimum(raw.astype(jnp.float32), smoothed)
    if valid is None:
        return score
    keep = valid | ~jnp.any(valid, axis=(1, 2), keepdims=True)
    return jnp.where(keep, score, -jnp.inf)


def best_grasp(maps: GraspMaps, cfg: GGCNNConfig = GGCNNConfig(), valid: Optional[jax.Array] = None) -> ImageGrasp:
    """Post-process GG-CNN maps (``(B, H, W)`` each) and pick each image's best grasp: the
    argmax of ``peak_score`` (``valid`` ``(B, H, W)`` bool or None, see there), with the
    smoothed quality, the angle and the width read there."""
    quality, angle, width_px = postprocess(maps, cfg)
    px = peak(peak_score(maps.quality, quality, valid))
    return ImageGrasp(px, _at(quality, px), _at(angle, px), _at(width_px, px))


# ----------------------------------------------------------------------------- world grasp


@flax.struct.dataclass
class WorldGrasp:
    """A grasp in the world frame: ``position`` ``(..., 3)`` metres; ``yaw`` ``(...,)`` radians
    in ``[-pi/2, pi/2)``, the closing axis ``(cos yaw, sin yaw)`` in the world xy plane (the
    convention of ``vags_jax.config``); ``width`` ``(...,)`` opening in metres."""

    position: jax.Array
    yaw: jax.Array
    width: jax.Array


def grasp_to_world(pixel, angle, width_px, depth, intrinsics, cam_pose) -> WorldGrasp:
    """An image grasp -> the world grasp, batched over leading axes ``...`` (broadcast).

    Args:
      pixel: ``(..., 2)`` [u, v] (int or float) in the image the intrinsics describe.
      angle: ``(...,)`` image closing-axis angle theta (module docstring).
      width_px: ``(...,)`` opening in pixels of that image.
      depth: ``(...,)`` metres along the optical axis at the pixel (``sample_depth``).
      intrinsics: ``(..., 3, 3)``; cam_pose: ``(..., 4, 4)`` camera-to-world, OpenCV axes.
    Returns:
      WorldGrasp: ``position = R p + t`` with ``p = depth ((u - cx) / fx, (v - cy) / fy, 1)``;
      the closing axis is the camera-frame offset between two points of equal depth one pixel
      apart along theta, ``a = (cos theta / fx, sin theta / fy, 0)``, turned into the world by
      ``R``, its xy direction giving ``yaw`` (folded into [-pi/2, pi/2): a parallel-jaw grasp is
      symmetric); ``width = width_px * depth * |a|`` (``= width_px * depth / fx`` when
      ``fx == fy``).  The yaw is exact for a camera looking straight down; for a tilted camera
      it is the xy direction of the closing axis laid on the plane of equal depth.
    """
    pixel = jnp.asarray(pixel, jnp.float32)
    angle = jnp.asarray(angle, jnp.float32)
    width_px = jnp.asarray(width_px, jnp.float32)
    depth = jnp.asarray(depth, jnp.float32)
    k = jnp.asarray(intrinsics, jnp.float32)
    pose = jnp.asarray(cam_pose, jnp.float32)
    _check(pixel.shape[-1:] == (2,), f"grasp_to_world: pixel must be (..., 2) [u, v], got {pixel.shape}")
    _check(k.shape[-2:] == (3, 3), f"grasp_to_world: intrinsics must be (..., 3, 3), got {k.shape}")
    _check(pose.shape[-2:] == (4, 4), f"grasp_to_world: cam_pose must be (..., 4, 4), got {pose.shape}")
    fx, fy, cx, cy = k[..., 0, 0], k[..., 1, 1], k[..., 0, 2], k[..., 1, 2]
    p_cam = jnp.stack(
        jnp.broadcast_arrays(depth * (pixel[..., 0] - cx) / fx, depth * (pixel[..., 1] - cy) / fy, depth),
        axis=-1,
    )
    rot, t = pose[..., :3, :3], pose[..., :3, 3]
    position = jnp.einsum("...ij,...j->...i", rot, p_cam) + t
    ax, ay = jnp.broadcast_arrays(jnp.cos(angle) / fx, jnp.sin(angle) / fy)
    a_cam = jnp.stack([ax, ay, jnp.zeros_like(ax)], axis=-1)
    a_world = jnp.einsum("...ij,...j->...i", rot, a_cam)
    yaw = jnp.arctan2(a_world[..., 1], a_world[..., 0])
    yaw = jnp.mod(yaw + math.pi / 2, math.pi) - math.pi / 2
    width = width_px * depth * jnp.linalg.norm(a_cam, axis=-1)
    return WorldGrasp(position, yaw, width)
