"""GG-CNN training labels: grasp candidates in an image -> quality / cos 2theta / sin 2theta /
width maps, by the centre-third rule.

A candidate is a grasp rectangle in image pixels (conventions of ``vags_jax.ggcnn.process``):
centre ``(u, v)``, closing-axis angle ``theta`` (the axis runs along ``(cos theta, sin theta)``
in ``(u, v)``), ``length`` = the gripper opening along the closing axis and ``jaw`` = the
rectangle's extent across it (the finger size), both in pixels, and whether the grasp succeeded.

Centre-third rule (GG-CNN): each candidate is shrunk to the centre third of its length.  A
pixel centre ``p`` is inside candidate ``c`` when::

    |(p - c) . (cos theta, sin theta)|  <= length / 6     (centre third along the closing axis)
    |(p - c) . (-sin theta, cos theta)| <= jaw / 2

(with a 1e-4 pixel tolerance so boundaries on exact pixel centres count despite rounding).

Quality (``mode``, ``GGCNNConfig.labels``):

* ``"success_ratio"`` (default): the share of successes among all candidates covering the
  pixel, failures included; 0 where none covers.  ``label_weight`` gives the loss weight: 1 on
  covered ("tried") pixels, ``untried_weight`` elsewhere.  With successes alone, about a fifth
  of the object pixels came out positive and the net learnt "top of an object"; failures now
  pull their pixels to 0 at full weight, while untried pixels are only weakly 0.
* ``"positives"`` (GG-CNN's Cornell rule): 1 inside any successful candidate, 0 elsewhere;
  failures are never drawn; every pixel has weight 1.

Inside a successful candidate: cos 2theta, sin 2theta and width = min(length / width_scale, 1)
(GG-CNN clips the opening at 150 px).  Where several successes cover a pixel, the one with the
highest index wins.  Outside every success these three maps are 0 (GG-CNN's code leaves cos
2theta at 1 there, as it takes the cosine of an angle map that is 0 outside; 0 keeps (cos, sin)
= (0, 0) = "no angle", which rotation augmentation leaves unchanged).
"""
from __future__ import annotations

import flax.struct
import jax
import jax.numpy as jnp

from vags_jax.nets.ggcnn import GraspMaps

TOLERANCE = 1e-4  # pixels
MODES = ("success_ratio", "positives")  # = config.GGCNN_LABELS


def _check(cond: bool, msg: str) -> None:
    if not cond:
        raise ValueError(msg)


@flax.struct.dataclass
class GraspCandidates:
    """Candidate grasps of images: leading axes ``...`` (e.g. ``(B,)``) then N candidates.

    center ``(..., N, 2)`` float [u, v] pixels; angle ``(..., N)`` radians; length ``(..., N)``
    opening along the closing axis, pixels; jaw ``(..., N)`` extent across it, pixels; success
    ``(..., N)`` bool.
    """

    center: jax.Array
    angle: jax.Array
    length: jax.Array
    jaw: jax.Array
    success: jax.Array


def _check_candidates(c: GraspCandidates) -> tuple[int, ...]:
    shape = tuple(jnp.shape(c.angle))
    _check(len(shape) >= 1, f"GraspCandidates.angle must be (..., N), got shape {shape}")
    _check(tuple(jnp.shape(c.center)) == shape + (2,),
           f"GraspCandidates.center must be (..., N, 2) = {shape + (2,)}, got {tuple(jnp.shape(c.center))}")
    for name in ("length", "jaw", "success"):
        got = tuple(jnp.shape(getattr(c, name)))
        _check(got == shape, f"GraspCandidates.{name} must have the shape of angle {shape}, got {got}")
    return shape


def _inside(center, theta, length, jaw, height: int, width: int) -> jax.Array:
    """Whether each pixel lies in each candidate's centre third.

    Candidate arrays ``(..., K)`` (center ``(..., K, 2)``) -> ``(..., K, height, width)`` bool.
    """
    u = jnp.arange(width, dtype=jnp.float32)[None, :]
    v = jnp.arange(height, dtype=jnp.float32)[:, None]
    e = lambda x: x[..., None, None]  # (..., K) -> (..., K, 1, 1)
    du = u - e(center[..., 0])
    dv = v - e(center[..., 1])
    c, s = e(jnp.cos(theta)), e(jnp.sin(theta))
    return ((jnp.abs(du * c + dv * s) <= e(length) / 6.0 + TOLERANCE)     # along the closing axis
            & (jnp.abs(-du * s + dv * c) <= e(jaw) / 2.0 + TOLERANCE))    # across it


def _draw(cands: GraspCandidates, height: int, width: int, chunk: int):
    """One pass over the candidates -> ``(winner, tried, won)``, each ``(..., height, width)``
    int32: 1-based index of the last success covering the pixel (0: none), and how many
    candidates / successes cover it."""
    shape = _check_candidates(cands)
    _check(isinstance(height, int) and isinstance(width, int) and height >= 1 and width >= 1,
           f"label_maps: height and width must be ints >= 1, got {height!r}, {width!r}")
    _check(isinstance(chunk, int) and chunk >= 1, f"label_maps: chunk must be an int >= 1, got {chunk!r}")
    lead, n = shape[:-1], shape[-1]
    center = jnp.asarray(cands.center, jnp.float32)
    theta = jnp.asarray(cands.angle, jnp.float32)
    length = jnp.asarray(cands.length, jnp.float32)
    jaw = jnp.asarray(cands.jaw, jnp.float32)
    success = jnp.asarray(cands.success, bool)
    real = jnp.ones(shape, bool)

    k = min(chunk, n)
    n_chunks = -(-n // k)
    pad = n_chunks * k - n

    def chunks(x, trailing=0):
        # (..., N[, 2]) -> (n_chunks, ..., k[, 2]); padding candidates are not real (never drawn).
        axis = x.ndim - 1 - trailing
        widths = [(0, 0)] * x.ndim
        widths[axis] = (0, pad)
        x = jnp.pad(x, widths)
        x = x.reshape(x.shape[:axis] + (n_chunks, k) + x.shape[axis + 1:])
        return jnp.moveaxis(x, axis, 0)

    xs = (chunks(center, 1), chunks(theta), chunks(length), chunks(jaw), chunks(success), chunks(real),
          jnp.arange(n_chunks, dtype=jnp.int32) * k)
    rank = jnp.arange(1, k + 1, dtype=jnp.int32)[:, None, None]

    def body(carry, x):
        winner, tried, won = carry
        c, t, l, j, ok, live, offset = x
        inside = _inside(c, t, l, j, height, width) & live[..., None, None]   # (..., k, H, W)
        pos = inside & ok[..., None, None]
        w = jnp.max(jnp.where(pos, rank, 0), axis=-3)
        winner = jnp.where(w > 0, w + offset, winner)
        return (winner, tried + jnp.sum(inside, axis=-3, dtype=jnp.int32),
                won + jnp.sum(pos, axis=-3, dtype=jnp.int32)), None

    zeros = jnp.zeros(lead + (height, width), jnp.int32)
    (winner, tried, won), _ = jax.lax.scan(body, (zeros, zeros, zeros), xs)
    return winner, tried, won


def label_maps(cands: GraspCandidates, height: int, width: int, width_scale: float = 150.0,
               chunk: int = 32, mode: str = "success_ratio") -> GraspMaps:
    """GG-CNN label maps of ``height x width`` images from their grasp candidates.

    Args:
      cands: GraspCandidates with leading axes ``...`` and N candidates.
      height, width: static image size in pixels.
      width_scale: the width map holds ``min(length / width_scale, 1)``.
      chunk: candidates tested at once (static).  Every pixel is tested against ``chunk``
        candidates in one vectorised step and a ``lax.scan`` runs over the chunks, so memory is
        about ``chunk * prod(...) * H * W`` numbers whatever N is.
      mode: ``"success_ratio"`` or ``"positives"`` (module docstring).
    Returns:
      GraspMaps, each ``(..., height, width)`` float32 (module docstring).
    """
    return labels_and_weight(cands, height, width, width_scale, chunk, mode)[0]


def labels_and_weight(cands: GraspCandidates, height: int, width: int, width_scale: float = 150.0,
                      chunk: int = 32, mode: str = "success_ratio", untried_weight: float = 0.1):
    """``label_maps`` and the loss weight map ``(..., height, width)`` float32 in one pass:
    ``"success_ratio"``: 1 where a candidate covers the pixel, ``untried_weight`` elsewhere;
    ``"positives"``: 1 everywhere (GG-CNN's unweighted loss)."""
    _check(mode in MODES, f"label mode must be one of {MODES}, got {mode!r}")
    winner, tried, won = _draw(cands, height, width, chunk)
    lead = winner.shape[:-2]
    hit = winner > 0
    flat = jnp.maximum(winner - 1, 0).reshape(lead + (height * width,))
    theta = jnp.asarray(cands.angle, jnp.float32)
    length = jnp.asarray(cands.length, jnp.float32)

    def pick(values):
        got = jnp.take_along_axis(values, flat, axis=-1).reshape(lead + (height, width))
        return jnp.where(hit, got, 0.0).astype(jnp.float32)

    if mode == "positives":
        quality, weight = hit.astype(jnp.float32), jnp.ones(hit.shape, jnp.float32)
    else:
        quality = (won / jnp.maximum(tried, 1)).astype(jnp.float32)
        weight = jnp.where(tried > 0, 1.0, untried_weight).astype(jnp.float32)
    maps = GraspMaps(
        quality=quality,
        cos=pick(jnp.cos(2 * theta)),
        sin=pick(jnp.sin(2 * theta)),
        width=pick(jnp.clip(length / width_scale, 0.0, 1.0)),
    )
    return maps, weight
