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

Parameters: 2,624 + 12,816 + 1,160 + 584 + 3,216 + 41,504 + 4 x 129 = 62,420.
Initialisation: Glorot-uniform kernels (GG-CNN's ``xavier_uniform_``), zero biases.

Output meaning (see ``vags_jax.ggcnn_process`` for the conventions):

* ``quality`` in [0, 1] (trained on 1 inside labelled grasps, 0 elsewhere);
* ``cos`` / ``sin`` = cos 2theta / sin 2theta of the grasp angle theta, the direction of the
  gripper's closing axis in the image, ``(du, dv) = (cos theta, sin theta)`` in pixel columns
  ``u`` and rows ``v`` (v downward);
* ``width`` = gripper opening in input pixels / ``GGCNNConfig.width_scale`` (150).
"""
from __future__ import annotations

from dataclasses import dataclass
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


class GGCNN(nn.Module):
    """GG-CNN: ``(B, H, W[, 1])`` preprocessed depth -> GraspMaps of ``(B, H, W)`` maps.

    The input is the output of ``ggcnn_process.preprocess_depth`` (depth minus its mean,
    clipped to [-1, 1]).  H and W must be multiples of 12 (300 x 300 in GG-CNN).
    """

    dtype: jnp.dtype = jnp.float32

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
