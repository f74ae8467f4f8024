"""Bilinear rotation of image batches about their centre (pure JAX, jittable, differentiable).

Geometry (the heightmap convention of ``vags_jax.config``): an image ``(H, W, C)`` has its row
index along +y and its column index along +x.  A point ``(x, y) = (col, row)``; the centre of
rotation is ``c = ((W - 1) / 2, (H - 1) / 2)``, the middle of the pixel grid (pixel centres sit at
integer coordinates).  ``R(a) = [[cos a, -sin a], [sin a, cos a]]`` turns a vector by ``a``
from +x towards +y, i.e. from +col towards +row (clockwise as displayed with row 0 at the top).

``rotate(images, a)`` turns the *content* by ``+a``::

    out(p) = in(R(-a) (p - c) + c)        p = (col, row) of an output pixel

so a feature at ``q`` in ``in`` appears at ``R(a) (q - c) + c`` in ``out``.  Example: a bright
pixel 3 columns right of the centre (+x) moves, for ``a = pi / 2``, to 3 rows below the centre
(+y).  ``unrotate(images, a) = rotate(images, -a)`` is its inverse.  Samples that fall outside
the source image read 0 (``mode="constant"``) or the nearest edge pixel (``mode="clamp"``).
"""
from __future__ import annotations

import jax
import jax.numpy as jnp


def sample_bilinear(image: jax.Array, rows: jax.Array, cols: jax.Array, mode: str = "constant") -> jax.Array:
    """Bilinear samples of one image at fractional pixel positions.

    Args:
      image: ``(H, W, C)``.
      rows, cols: same shape ``S`` (any), fractional row / column coordinates (pixel centres at
        integers).
      mode: ``"constant"`` (outside reads 0) or ``"clamp"`` (edge pixels extend outward).
    Returns:
      ``S + (C,)``, dtype of ``image`` promoted with float32.
    """
    if mode not in ("constant", "clamp"):
        raise ValueError(f"sample_bilinear: mode must be 'constant' or 'clamp', got {mode!r}")
    h, w = image.shape[0], image.shape[1]
    r0f = jnp.floor(rows)
    c0f = jnp.floor(cols)
    fr = (rows - r0f)[..., None]
    fc = (cols - c0f)[..., None]
    r0 = r0f.astype(jnp.int32)
    c0 = c0f.astype(jnp.int32)

    def tap(r, c):
        v = image[jnp.clip(r, 0, h - 1), jnp.clip(c, 0, w - 1)]
        if mode == "constant":
            inside = (r >= 0) & (r < h) & (c >= 0) & (c < w)
            v = jnp.where(inside[..., None], v, jnp.zeros((), v.dtype))
        return v

    top = tap(r0, c0) * (1 - fc) + tap(r0, c0 + 1) * fc
    bottom = tap(r0 + 1, c0) * (1 - fc) + tap(r0 + 1, c0 + 1) * fc
    return top * (1 - fr) + bottom * fr


def source_coords(height: int, width: int, angle: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Where ``rotate`` samples its input, for every output pixel.

    Args:
      height, width: static image size.
      angle: scalar, radians (see the module docstring for the direction).
    Returns:
      ``(rows, cols)``, each ``(height, width)`` float32: output pixel ``(i, j)`` reads the input
      at ``R(-angle) ((j, i) - c) + c``.
    """
    cy, cx = (height - 1) / 2.0, (width - 1) / 2.0
    y = jnp.arange(height, dtype=jnp.float32)[:, None] - cy
    x = jnp.arange(width, dtype=jnp.float32)[None, :] - cx
    cos, sin = jnp.cos(angle), jnp.sin(angle)
    # R(-a) = [[cos, sin], [-sin, cos]] applied to (x, y).
    src_x = cos * x + sin * y + cx
    src_y = -sin * x + cos * y + cy
    return src_y, src_x


def rotate(images: jax.Array, angles: jax.Array, mode: str = "constant") -> jax.Array:
    """Rotate each image's content by its angle (bilinear, about the image centre).

    Args:
      images: ``(N, H, W, C)``.
      angles: ``(N,)`` radians; positive turns content from +x (col) towards +y (row).
    Returns:
      ``(N, H, W, C)``; pixels whose source lies outside the image are 0 (``mode="constant"``).
    """
    n, h, w, _ = images.shape
    angles = jnp.broadcast_to(jnp.asarray(angles, jnp.float32), (n,))

    def one(image, angle):
        rows, cols = source_coords(h, w, angle)
        return sample_bilinear(image, rows, cols, mode)

    return jax.vmap(one)(images, angles)


def unrotate(images: jax.Array, angles: jax.Array, mode: str = "constant") -> jax.Array:
    """Inverse of ``rotate``: ``unrotate(rotate(x, a), a) ~= x`` (exact up to resampling).

    Args:
      images: ``(N, H, W, C)``; angles: ``(N,)`` radians, the angles given to ``rotate``.
    Returns:
      ``(N, H, W, C)``.
    """
    return rotate(images, -jnp.asarray(angles, jnp.float32), mode)
