"""DenseNet-121 feature extractor, laid out like torchvision's ``densenet121().features``.

Structure (Huang et al. 2017; torchvision ``DenseNet(growth_rate=32, block_config=(6, 12, 24,
16), num_init_features=64, bn_size=4)``)::

    conv0 7x7/2 pad 3 (no bias) - norm0 - relu - maxpool 3x3/2 pad 1
    denseblock1 (6 layers)  - transition1 (BN-ReLU-1x1 conv to half the channels - avgpool 2x2/2)
    denseblock2 (12 layers) - transition2
    denseblock3 (24 layers) - transition3
    denseblock4 (16 layers) - norm5
    dense layer: norm1-relu-conv1 1x1 (4 * 32 ch) - norm2-relu-conv2 3x3 pad 1 (32 ch), concatenated

Input ``(N, H, W, 3)``, output ``(N, ceil-ish(H / 32), ., 1024)`` (exactly ``H / 32`` when H is a
multiple of 32) after ``norm5`` and no ReLU, like torchvision.  Padding is torchvision's explicit
symmetric padding, so pretrained weights see the same alignment.  Output cell ``k`` is centred on
input pixel ``32 k + 14`` (stem: ``4k``; each transition's 2x2 average moves it by half a cell).

Submodule names mirror torchvision's state-dict keys (``conv0``, ``denseblock1/denselayer1/norm1``,
``transition1/conv``, ``norm5``...) so ``pretrained.py`` can map them one to one.  BatchNorm:
momentum 0.9 (torch 0.1), epsilon 1e-5; ``train=True`` uses batch statistics and updates the
``batch_stats`` collection.  In eval mode the BatchNorms that follow a convolution (``norm0``, each
``norm2``) are folded into its kernel and a bias (``conv_bn_relu``); the stem runs by
space-to-depth (``StemConv``) and each transition pools before its 1x1 conv
(``pooled_pointwise_conv``), in both modes; parameters are the same.  Parameters are float32; ``dtype`` is the compute dtype.
"""
from __future__ import annotations

from typing import Optional, Sequence

import flax.linen as nn
import jax
import jax.numpy as jnp

STRIDE = 32
OFFSET = 14.0  # output cell k is centred on input pixel STRIDE * k + OFFSET
OUT_CHANNELS = 1024
BLOCK_CONFIG = (6, 12, 24, 16)
GROWTH = 32
BN_SIZE = 4
INIT_FEATURES = 64
# torch's kaiming_normal_ (fan_in, ReLU gain): an untruncated normal, std sqrt(2 / fan_in).
HE_NORMAL = nn.initializers.variance_scaling(2.0, "fan_in", "normal")
BN_EPSILON = 1e-5  # torch's BatchNorm2d default


def batch_norm(name: str, train: bool, dtype, axis_name: Optional[str] = None) -> nn.BatchNorm:
    """torch-equivalent BatchNorm2d (momentum 0.1 -> flax 0.9, eps 1e-5), float32 params.
    ``axis_name``: in train mode the batch statistics are averaged over that mapped axis (data
    parallel training: the statistics of the whole batch, split over devices)."""
    return nn.BatchNorm(
        use_running_average=not train, momentum=0.9, epsilon=BN_EPSILON,
        dtype=dtype, param_dtype=jnp.float32, axis_name=axis_name, name=name,
    )


def conv(features: int, kernel: int, name: str, dtype, stride: int = 1, pad: int = 0) -> nn.Conv:
    """Bias-free conv with torch-style symmetric padding and He-normal init (torchvision's)."""
    return nn.Conv(
        features, (kernel, kernel), strides=(stride, stride), padding=((pad, pad), (pad, pad)),
        use_bias=False, dtype=dtype, param_dtype=jnp.float32,
        kernel_init=HE_NORMAL, name=name,
    )


def folded_batch_norm(variables: dict) -> tuple[jax.Array, jax.Array]:
    """An eval-mode BatchNorm's variables -> ``(mul, shift)``, each ``(C,)`` float32, with
    ``bn(y) = y * mul + shift``."""
    p, s = variables["params"], variables["batch_stats"]
    mul = p["scale"] * jax.lax.rsqrt(s["var"] + BN_EPSILON)
    return mul, p["bias"] - s["mean"] * mul


def conv_bn_relu(x: jax.Array, c: "nn.Conv | StemConv", bn: nn.BatchNorm, train: bool, initializing: bool) -> jax.Array:
    """``relu(bn(c(x)))``.  In eval mode the BatchNorm is folded into the conv's kernel and a bias
    (conv + bias + ReLU: one pass less over the activations, 1.10 x for a DenseNet-121 pass on an
    H200, bench/RESULTS.md); train mode and init call the modules as they are."""
    if train or initializing:
        return nn.relu(bn(c(x)))
    mul, shift = folded_batch_norm(bn.variables)
    if isinstance(c, StemConv):
        y = c(x, mul)
    else:
        kernel = (c.variables["params"]["kernel"] * mul).astype(c.dtype)
        y = jax.lax.conv_general_dilated(x.astype(c.dtype), kernel, c.strides, c.padding,
                                         dimension_numbers=("NHWC", "HWIO", "NHWC"))
    return nn.relu(y + shift.astype(c.dtype))


def stride2_conv_by_space_to_depth(x: jax.Array, kernel: jax.Array, pad: int) -> jax.Array:
    """A stride-2 conv with symmetric padding ``pad`` computed as a stride-1 conv over the 2 x 2
    space-to-depth of the padded input, the kernel zero-padded to an even size: kernel tap
    ``(2a + r, 2b + s)`` reads block ``(a, b)`` at offset ``(r, s)``.  The same sums in fewer, wider
    taps, for a first conv over few channels, which is memory-bound.  ``x`` ``(N, H, W, C)`` with
    even H, W; ``kernel`` ``(k, k, C, F)`` in x's dtype -> ``(N, (H + 2 pad - k) // 2 + 1, ., F)``."""
    n, h, w, c = x.shape
    k, f = kernel.shape[0], kernel.shape[-1]
    half = (k + 1) // 2
    xp = jnp.pad(x, ((0, 0), (pad, pad), (pad, pad), (0, 0)))
    m_h, m_w = h // 2 + pad, w // 2 + pad
    blocks = xp.reshape(n, m_h, 2, m_w, 2, c).transpose(0, 1, 3, 2, 4, 5).reshape(n, m_h, m_w, 4 * c)
    if k % 2:
        kernel = jnp.pad(kernel, ((0, 1), (0, 1), (0, 0), (0, 0)))
    kernel = kernel.reshape(half, 2, half, 2, c, f).transpose(0, 2, 1, 3, 4, 5).reshape(half, half, 4 * c, f)
    return jax.lax.conv_general_dilated(blocks, kernel, (1, 1), "VALID", dimension_numbers=("NHWC", "HWIO", "NHWC"))


class StemConv(nn.Module):
    """``conv(features, 7, stride 2, pad 3)``: its parameter (``kernel`` ``(7, 7, C, features)``) and
    its result, computed for even H, W by ``stride2_conv_by_space_to_depth``: over 3 input
    channels the plain conv is memory-bound, and this form took the stem from 20.3 to 10.3 ms per
    1,024 inputs of 320 x 320 on an H200 (bench/RESULTS.md).  ``scale`` ``(features,)``
    multiplies the kernel's output channels (an eval-mode BatchNorm folded in).
    ``(N, H, W, C) -> (N, ceil(H / 2), ceil(W / 2), features)``."""

    features: int
    dtype: jnp.dtype = jnp.float32

    @nn.compact
    def __call__(self, x: jax.Array, scale: Optional[jax.Array] = None) -> jax.Array:
        n, h, w, c = x.shape
        kernel = self.param("kernel", HE_NORMAL, (7, 7, c, self.features), jnp.float32)
        if scale is not None:
            kernel = kernel * scale
        x, kernel = x.astype(self.dtype), kernel.astype(self.dtype)
        if h % 2 or w % 2:
            return jax.lax.conv_general_dilated(x, kernel, (2, 2), ((3, 3), (3, 3)),
                                                dimension_numbers=("NHWC", "HWIO", "NHWC"))
        return stride2_conv_by_space_to_depth(x, kernel, 3)


class DenseLayer(nn.Module):
    """BN-ReLU-1x1 conv-BN-ReLU-3x3 conv: ``(N, H, W, C_in) -> (N, H, W, growth)``."""

    growth: int = GROWTH
    bn_size: int = BN_SIZE
    dtype: jnp.dtype = jnp.float32
    axis_name: Optional[str] = None  # BatchNorm's (``batch_norm``)

    @nn.compact
    def __call__(self, x: jax.Array, train: bool) -> jax.Array:
        y = nn.relu(batch_norm("norm1", train, self.dtype, self.axis_name)(x))
        y = conv_bn_relu(y, conv(self.bn_size * self.growth, 1, "conv1", self.dtype),
                         batch_norm("norm2", train, self.dtype, self.axis_name), train, self.is_initializing())
        return conv(self.growth, 3, "conv2", self.dtype, pad=1)(y)


class DenseBlock(nn.Module):
    """``n_layers`` dense layers: ``(N, H, W, C) -> (N, H, W, C + n_layers * growth)``."""

    n_layers: int
    growth: int = GROWTH
    bn_size: int = BN_SIZE
    dtype: jnp.dtype = jnp.float32
    axis_name: Optional[str] = None

    @nn.compact
    def __call__(self, x: jax.Array, train: bool) -> jax.Array:
        for i in range(self.n_layers):
            y = DenseLayer(self.growth, self.bn_size, self.dtype, self.axis_name, name=f"denselayer{i + 1}")(x, train)
            x = jnp.concatenate([x, y], axis=-1)
        return x


def pooled_pointwise_conv(x: jax.Array, c: nn.Conv) -> jax.Array:
    """``avg_pool 2x2/2 (c(x))`` for a bias-free 1x1 conv ``c``, computed as ``c(avg_pool(x))``:
    the conv mixes channels per pixel and the pool averages pixels per channel, both linear, so
    they commute, and the conv runs on a quarter of the pixels (1.06x on DenseNet-121's eval pass
    on an H200, bench/RESULTS.md).  Same result up to rounding.
    ``(N, H, W, C) -> (N, H // 2, W // 2, features)``."""
    return c(nn.avg_pool(x, (2, 2), strides=(2, 2), padding="VALID"))


class Transition(nn.Module):
    """BN-ReLU-1x1 conv-avgpool 2x2/2 (the conv and the pool by ``pooled_pointwise_conv``):
    ``(N, H, W, C) -> (N, H // 2, W // 2, features)``."""

    features: int
    dtype: jnp.dtype = jnp.float32
    axis_name: Optional[str] = None

    @nn.compact
    def __call__(self, x: jax.Array, train: bool) -> jax.Array:
        y = nn.relu(batch_norm("norm", train, self.dtype, self.axis_name)(x))
        return pooled_pointwise_conv(y, conv(self.features, 1, "conv", self.dtype))


class DenseNet121(nn.Module):
    """DenseNet-121 ``features``: ``(N, H, W, 3) -> (N, H / 32, W / 32, 1024)``."""

    block_config: Sequence[int] = BLOCK_CONFIG
    growth: int = GROWTH
    bn_size: int = BN_SIZE
    init_features: int = INIT_FEATURES
    dtype: jnp.dtype = jnp.float32
    axis_name: Optional[str] = None

    @nn.compact
    def __call__(self, x: jax.Array, train: bool = False) -> jax.Array:
        x = x.astype(self.dtype)
        x = conv_bn_relu(x, StemConv(self.init_features, self.dtype, name="conv0"),
                         batch_norm("norm0", train, self.dtype, self.axis_name), train, self.is_initializing())
        x = nn.max_pool(x, (3, 3), strides=(2, 2), padding=((1, 1), (1, 1)))
        channels = self.init_features
        for b, n_layers in enumerate(self.block_config):
            x = DenseBlock(n_layers, self.growth, self.bn_size, self.dtype, self.axis_name,
                           name=f"denseblock{b + 1}")(x, train)
            channels += n_layers * self.growth
            if b != len(self.block_config) - 1:
                channels //= 2
                x = Transition(channels, self.dtype, self.axis_name, name=f"transition{b + 1}")(x, train)
        return batch_norm("norm5", train, self.dtype, self.axis_name)(x)
