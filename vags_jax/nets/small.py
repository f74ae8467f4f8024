"""A small fast trunk: three strided 4x4 convs and one 3x3 conv (stride 8).

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

from .densenet import batch_norm, conv

STRIDE = 8
OFFSET = 3.5


def out_channels(width: int) -> int:
    return 4 * width


def param_count(width: int, in_channels: int = 3) -> int:
    """Number of trainable parameters of ``SmallTrunk(width)`` (conv weights + BN affine)."""
    w = width
    convs = 16 * in_channels * w + 16 * w * 2 * w + 16 * 2 * w * 4 * w + 9 * 4 * w * 4 * w
    return convs + 2 * (w + 2 * w + 4 * w)


class SmallTrunk(nn.Module):
    """``(N, H, W, 3) -> (N, H / 8, W / 8, 4 * width)``."""

    width: int = 32
    dtype: jnp.dtype = jnp.float32
    axis_name: Optional[str] = None  # BatchNorm's (``densenet.batch_norm``)

    @nn.compact
    def __call__(self, x: jax.Array, train: bool = False) -> jax.Array:
        x = x.astype(self.dtype)
        for i, mult in enumerate((1, 2, 4)):
            x = conv(mult * self.width, 4, f"conv{i}", self.dtype, stride=2, pad=1)(x)
            x = nn.relu(batch_norm(f"norm{i}", train, self.dtype, self.axis_name)(x))
        return conv(4 * self.width, 3, "conv3", self.dtype, pad=1)(x)
