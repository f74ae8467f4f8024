"""A small fast trunk: three strided 4x4 convs and one 3x3 conv (stride 8).

Two rewrites of the same arithmetic make the two trunks' eval-mode pass (the actor's and the
target network's) 1.45 x faster on an H100 (bench/RESULTS.md, "Where the update's time goes"):
the first conv, over 3 input channels and memory-bound, runs as a 2x2 / 1 conv over the 2 x 2
space-to-depth of its padded input (``StridedConv``); in eval mode each BatchNorm is folded into
its conv's kernel and a bias (``folded_batch_norm``).  Parameters and train mode are unchanged.

::

    conv 4x4/2 pad 1 (w)  - BN - ReLU
    conv 4x4/2 pad 1 (2w) - BN - ReLU
    conv 4x4/2 pad 1 (4w) - BN - ReLU
    conv 3x3/1 pad 1 (4w)                 (no BN/ReLU: the Q-head starts with BN-ReLU)

Input ``(N, H, W, 3)``, output ``(N, H / 8, W / 8, 4 w)`` for H, W multiples of 8.  A 4x4/2 conv
with padding 1 centres output cell ``k`` on input ``2k + 0.5``, so cell ``k`` of the trunk output is
centred on input pixel ``8 k + 3.5`` (the symmetric alignment).  With ``w = 32``: 312,832 conv
weights + 448 BN affine = 313,280 parameters (see ``param_count``).
"""
from __future__ import annotations

from typing import Optional

import flax.linen as nn
import jax
import jax.numpy as jnp

from .densenet import HE_NORMAL, batch_norm, conv, folded_batch_norm, stride2_conv_by_space_to_depth

STRIDE = 8
OFFSET = 3.5


def out_channels(width: int) -> int:
    return 4 * width


def param_count(width: int, in_channels: int = 3) -> int:
    """Number of trainable parameters of ``SmallTrunk(width)`` (conv weights + BN affine)."""
    w = width
    convs = 16 * in_channels * w + 16 * w * 2 * w + 16 * 2 * w * 4 * w + 9 * 4 * w * 4 * w
    return convs + 2 * (w + 2 * w + 4 * w)


class StridedConv(nn.Module):
    """``nn.Conv(features, (4, 4), strides 2, padding 1, no bias)``: its parameter (``kernel``
    ``(4, 4, C, features)``) and its result.  ``space_to_depth``: computed as a 2x2 / 1 conv over
    the padded input's 2 x 2 space-to-depth (``densenet.stride2_conv_by_space_to_depth``).
    ``scale`` ``(features,)`` multiplies the kernel's output channels (an eval-mode BatchNorm
    folded in).  ``(N, H, W, C) -> (N, H / 2, W / 2, features)`` for even H, W."""

    features: int
    dtype: jnp.dtype = jnp.float32
    space_to_depth: bool = False

    @nn.compact
    def __call__(self, x: jax.Array, scale: Optional[jax.Array] = None) -> jax.Array:
        n, h, w, c = x.shape
        if h % 2 or w % 2:
            raise ValueError(f"StridedConv needs an even height and width, got {h} x {w}")
        kernel = self.param("kernel", HE_NORMAL, (4, 4, c, self.features), jnp.float32)
        if scale is not None:
            kernel = kernel * scale
        x = x.astype(self.dtype)
        if not self.space_to_depth:
            return jax.lax.conv_general_dilated(x, kernel.astype(self.dtype), (2, 2), ((1, 1), (1, 1)),
                                                dimension_numbers=("NHWC", "HWIO", "NHWC"))
        return stride2_conv_by_space_to_depth(x, kernel.astype(self.dtype), 1)


class SmallTrunk(nn.Module):
    """``(N, H, W, 3) -> (N, H / 8, W / 8, 4 * width)``."""

    width: int = 32
    dtype: jnp.dtype = jnp.float32
    axis_name: Optional[str] = None  # BatchNorm's (``densenet.batch_norm``)

    @nn.compact
    def __call__(self, x: jax.Array, train: bool = False) -> jax.Array:
        x = x.astype(self.dtype)
        for i, mult in enumerate((1, 2, 4)):
            c = StridedConv(mult * self.width, self.dtype, space_to_depth=(i == 0), name=f"conv{i}")
            bn = batch_norm(f"norm{i}", train, self.dtype, self.axis_name)
            if train or self.is_initializing():
                x = nn.relu(bn(c(x)))
            else:  # BatchNorm folded into the conv: conv + bias + ReLU, one pass less over the activations
                mul, shift = folded_batch_norm(bn.variables)
                x = nn.relu(c(x, mul) + shift.astype(self.dtype))
        return conv(4 * self.width, 3, "conv3", self.dtype, pad=1)(x)
