"""GG-CNN (Morrison et al. 2018): a 62,420-parameter fully convolutional grasp network.

Architecture (all convolutions with bias; ReLU after every layer except the four heads)::

    depth (B, H, W, 1)
    conv   32  9x9 /3  pad 3            -> (B, H/3,  W/3,  32)
    conv   16  5x5 /2  pad 2            -> (B, H/6,  W/6,  16)
    conv    8  3x3 /2  pad 1            -> (B, H/12, W/12,  8)
    convT   8  3x3 /2  (torch pad 1, output_padding 1)  -> (B, H/6,  W/6,  8)
    convT  16  5x5 /2  (torch pad 2, output_padding 1)  -> (B, H/3,  W/3, 16)
    convT  32  9x9 /3  (torch pad 3, output_padding 1)  -> (B, H+1,  W+1, 32)
    four heads, conv 1 channel 2x2, no padding          -> (B, H, W) each:
        quality, cos 2theta, sin 2theta, width

For the standard 300 x 300 input the sizes are 100, 50, 25, 50, 100, 301, 300 (GG-CNN's own
layer arithmetic).  H and W must be multiples of 12 for the output to match the input (300 =
12 x 25; the tests use 24).  A torch ``ConvTranspose2d(k, stride s, padding p, output_padding
q)`` is a convolution over the input dilated by ``s`` and padded by ``(k - 1 - p, k - 1 - p +
q)``; the transposed convs here are written with exactly that explicit padding, so output sizes
and pixel alignment match the original.

The transposed convolutions are computed phase by phase on the undilated input
(``conv_transpose_subpixel``): the same parameters and outputs as flax's ``nn.ConvTranspose``
with that padding, without the s^2 - 1 of every s^2 products with the zeros a dilated input
holds.

Parameters: 2,624 + 12,816 + 1,160 + 584 + 3,216 + 41,504 + 4 x 129 = 62,420.
Initialisation: Glorot-uniform kernels (GG-CNN's ``xavier_uniform_``), zero biases.

Output meaning (see ``vags_jax.ggcnn.process`` for the conventions):

* ``quality`` in [0, 1] (trained on 1 inside labelled grasps, 0 elsewhere);
* ``cos`` / ``sin`` = cos 2theta / sin 2theta of the grasp angle theta, the direction of the
  gripper's closing axis in the image, ``(du, dv) = (cos theta, sin theta)`` in pixel columns
  ``u`` and rows ``v`` (v downward);
* ``width`` = gripper opening in input pixels / ``GGCNNConfig.width_scale`` (150).
"""
from __future__ import annotations

from typing import Optional

import flax.linen as nn
import flax.struct
import jax
import jax.numpy as jnp

from vags_jax.config import GGCNN_ROTATIONS, GGCNN_SIZE_MULTIPLE, GGCNNConfig  # noqa: F401 (re-exported)

# The network is fixed by the paper: filters, kernels, strides and torch paddings per layer.
FILTERS = (32, 16, 8, 8, 16, 32)
KERNELS = (9, 5, 3, 3, 5, 9)
STRIDES = (3, 2, 2, 2, 2, 3)
PADDINGS = (3, 2, 1, 1, 2, 3)  # torch `padding` of each layer
OUTPUT_PADDING = 1  # torch `output_padding` of each transposed conv
HEAD_KERNEL = 2
SIZE_MULTIPLE = 12  # input H, W must be multiples of this
N_PARAMS = 62_420
HEADS = ("quality", "cos", "sin", "width")



def _check(cond: bool, msg: str) -> None:
    if not cond:
        raise ValueError(msg)


@flax.struct.dataclass
class GraspMaps:
    """The four GG-CNN maps, each ``(..., H, W)`` float32: network output or training labels."""

    quality: jax.Array
    cos: jax.Array  # cos 2theta
    sin: jax.Array  # sin 2theta
    width: jax.Array  # opening in pixels / width_scale

    def stack(self) -> jax.Array:
        """``(..., H, W, 4)`` in the order quality, cos, sin, width."""
        return jnp.stack([self.quality, self.cos, self.sin, self.width], axis=-1)

    @staticmethod
    def unstack(x: jax.Array) -> "GraspMaps":
        """Inverse of ``stack``: ``(..., H, W, 4)`` -> GraspMaps."""
        return GraspMaps(x[..., 0], x[..., 1], x[..., 2], x[..., 3])


def check_network_input(depth) -> None:
    """Raise ValueError unless ``depth`` is a float ``(B, H, W)`` or ``(B, H, W, 1)`` array with
    H, W multiples of 12.  Works on tracers too (only shapes and dtypes are read)."""
    shape = tuple(getattr(depth, "shape", ()))
    dtype = getattr(depth, "dtype", None)
    _check(
        len(shape) == 3 or (len(shape) == 4 and shape[-1] == 1),
        f"GGCNN: depth must have shape (B, H, W) or (B, H, W, 1), got {shape}; "
        "add a batch axis for a single image",
    )
    _check(
        dtype is not None and jnp.issubdtype(dtype, jnp.floating),
        f"GGCNN: depth must be a float array (normalised depth), got dtype {dtype}",
    )
    h, w = shape[1], shape[2]
    _check(
        h >= SIZE_MULTIPLE and w >= SIZE_MULTIPLE and h % SIZE_MULTIPLE == 0 and w % SIZE_MULTIPLE == 0,
        f"GGCNN: depth height and width must be multiples of {SIZE_MULTIPLE} (e.g. 300 x 300) "
        f"for the output to match the input, got {h} x {w}",
    )


def conv_transpose_subpixel(x: jax.Array, kernel: jax.Array, stride: int, pad: tuple[int, int]) -> jax.Array:
    """``lax.conv_transpose`` (flax ``nn.ConvTranspose``, ``transpose_kernel=False``) with explicit
    padding ``pad`` = (low, high) on both spatial axes, computed without dilating the input.

    The transposed convolution is a convolution over the input dilated by ``stride`` (s - 1 zeros
    between pixels): (s^2 - 1) / s^2 of its products are with zeros.  Output pixel ``o = s j + r``
    only meets kernel taps ``t = t0 + s m`` (``t0 = (low - r) mod s``) and input pixels
    ``j + m + c`` (``c = (r + t0 - low) / s``), so each of the s^2 output phases is an ordinary
    convolution of the undilated input with every s-th tap; the phases are then interleaved.
    Same result (to float rounding), ~s^2 fewer operations forward and backward.

    x: (B, H, W, Cin); kernel: (k, k, Cin, Cout) -> (B, Ho, Wo, Cout) with
    ``Ho = (H - 1) s + 1 + low + high - k + 1``.
    """
    b, h, w, _ = x.shape
    k = kernel.shape[0]
    lo, hi = pad
    dn = ("NHWC", "HWIO", "NHWC")

    def phase_geometry(n, r):
        length = (n - 1) * stride + 1 + lo + hi - k + 1
        t0 = (lo - r) % stride
        taps = max(0, -(-(k - t0) // stride))
        c = (r + t0 - lo) // stride
        outs = max(0, -(-(length - r) // stride))
        return length, t0, taps, c, outs

    ho, wo = phase_geometry(h, 0)[0], phase_geometry(w, 0)[0]
    jy, jx = -(-ho // stride), -(-wo // stride)
    rows = []
    for ry in range(stride):
        _, ty, my, cy, ny = phase_geometry(h, ry)
        cols = []
        for rx in range(stride):
            _, tx, mx, cx, nx = phase_geometry(w, rx)
            if my == 0 or mx == 0 or ny == 0 or nx == 0:
                cols.append(jnp.zeros((b, jy, jx, kernel.shape[-1]), x.dtype))
                continue
            sub = kernel[ty::stride, tx::stride][:my, :mx]
            xp = jax.lax.pad(x, jnp.zeros((), x.dtype),
                             ((0, 0, 0), (-cy, ny + my - 1 - h + cy, 0), (-cx, nx + mx - 1 - w + cx, 0), (0, 0, 0)))
            z = jax.lax.conv_general_dilated(xp, sub, (1, 1), "VALID", dimension_numbers=dn)
            cols.append(jnp.pad(z, ((0, 0), (0, jy - ny), (0, jx - nx), (0, 0))))
        rows.append(jnp.stack(cols, axis=3))  # (B, jy, jx, s, C): column phase
    y = jnp.stack(rows, axis=2)  # (B, jy, s, jx, s, C)
    y = y.reshape(b, jy * stride, jx * stride, kernel.shape[-1])
    return y[:, :ho, :wo]


class SubPixelConvTranspose(nn.Module):
    """A strided transposed convolution with flax ``nn.ConvTranspose``'s parameters (``kernel``
    (k, k, Cin, Cout), ``bias``) and result, computed by ``conv_transpose_subpixel``."""

    features: int
    kernel_size: int
    stride: int
    pad: tuple[int, int]
    dtype: jnp.dtype = jnp.float32

    @nn.compact
    def __call__(self, x):
        k = self.kernel_size
        kernel = self.param("kernel", nn.initializers.glorot_uniform(), (k, k, x.shape[-1], self.features),
                            jnp.float32)
        bias = self.param("bias", nn.initializers.zeros, (self.features,), jnp.float32)
        x = x.astype(self.dtype)
        y = conv_transpose_subpixel(x, kernel.astype(self.dtype), self.stride, self.pad)
        return y + bias.astype(self.dtype)


class GGCNN(nn.Module):
    """GG-CNN: ``(B, H, W[, 1])`` preprocessed depth -> GraspMaps of ``(B, H, W)`` maps.

    The input is the output of ``ggcnn_process.preprocess_depth`` (depth minus its mean,
    clipped to [-1, 1]).  H and W must be multiples of 12 (300 x 300 in GG-CNN).
    """

    dtype: jnp.dtype = jnp.float32
    # True: transposed convolutions phase by phase (``conv_transpose_subpixel``); False: flax's
    # ``nn.ConvTranspose`` on the dilated input.  Same parameters and outputs (bench/ggcnn_speed.py
    # times both).
    subpixel: bool = True

    @nn.compact
    def __call__(self, depth: jax.Array) -> GraspMaps:
        check_network_input(depth)
        x = depth if depth.ndim == 4 else depth[..., None]
        x = x.astype(self.dtype)
        init = dict(kernel_init=nn.initializers.glorot_uniform(), bias_init=nn.initializers.zeros,
                    dtype=self.dtype, param_dtype=jnp.float32)
        for i in range(3):
            k, s, p = KERNELS[i], STRIDES[i], PADDINGS[i]
            x = nn.Conv(FILTERS[i], (k, k), strides=(s, s), padding=((p, p), (p, p)),
                        name=f"conv{i + 1}", **init)(x)
            x = nn.relu(x)
        for i in range(3, 6):
            k, s, p = KERNELS[i], STRIDES[i], PADDINGS[i]
            pad = (k - 1 - p, k - 1 - p + OUTPUT_PADDING)
            if self.subpixel:
                x = SubPixelConvTranspose(FILTERS[i], k, s, pad, dtype=self.dtype, name=f"convt{i - 2}")(x)
            else:
                x = nn.ConvTranspose(FILTERS[i], (k, k), strides=(s, s), padding=(pad, pad),
                                     name=f"convt{i - 2}", **init)(x)
            x = nn.relu(x)
        outs = [
            nn.Conv(1, (HEAD_KERNEL, HEAD_KERNEL), padding="VALID", name=f"{name}_head", **init)(x)[..., 0]
            for name in HEADS
        ]
        return GraspMaps(*[o.astype(jnp.float32) for o in outs])


def init_ggcnn(key: jax.Array, model: Optional[GGCNN] = None, size: int = 300) -> dict:
    """GG-CNN parameters ``{"params": ...}`` (62,420 numbers), initialised at a ``size`` input.

    The parameters do not depend on ``size`` (the network is fully convolutional); a small
    ``size`` (a multiple of 12) only makes initialisation cheaper.  Compiled with ``jit`` (one
    program instead of dozens of eager ones).
    """
    model = GGCNN() if model is None else model
    return jax.jit(model.init)(key, jnp.zeros((1, size, size, 1), jnp.float32))
