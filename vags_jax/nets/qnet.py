"""Two-stream fully convolutional Q-networks: GDNet (16 rotations) and VANet (no rotation).

Pipeline, for heightmaps ``colour (B, H, W, 3)`` uint8 (0..255) and ``height (B, H, W)`` float32
metres (as in VPG):

1. Zero-pad both maps to ``P x P`` (heightmap centred; padded colour is black, padded height 0)
   with ``P = padded_size(max(H, W), stride)``: ``ceil(H * sqrt 2)`` rounded up to a multiple of the
   trunk stride, so no rotation cuts heightmap content (224 -> 320 for both trunks here).
2. GDNet only: rotate the padded maps (bilinear, ``rotation.rotate``) by ``-theta_r`` with
   ``theta_r = r * 2 pi / n_rotations`` (``r * pi / 8`` for 16; ``r * pi / n_rotations`` with
   ``half_turn``, the rotations over half a turn).  By the convention of
   ``vags_jax.config`` the gripper's closing axis for index ``r`` points along ``(cos theta_r,
   sin theta_r)`` in (col, row); turning the content by ``-theta_r`` puts that axis along the
   network input's horizontal (+col) axis: the network always judges a grasp whose fingers close
   left-right in its own input.  The ``B * K`` rotated copies are folded into one trunk batch.
3. Normalise: colour / 255 then ImageNet mean / std; height cloned to 3 channels,
   ``(h - 0.01) / 0.03``.
4. Colour trunk and depth trunk (``densenet121``: 1024 ch at stride 32; ``small``: 4 w ch at
   stride 8), concatenated, head BN-ReLU-1x1 conv (``head_channels``, no bias)-BN-ReLU-1x1 conv (1,
   with bias, float32) -> a coarse map ``(B * K, P / s, P / s)``.
5. Rotate back by ``+theta_r``, upsample bilinearly and crop to ``(H, W)`` in one step: each
   heightmap pixel ``q`` (in padded coordinates) reads the coarse map bilinearly at
   ``(R(-theta_r) (q - c) + c - offset) / stride`` (edge-clamped), where coarse cell ``k`` is
   centred on input pixel ``stride * k + offset``.  This is "unrotate then bilinear upsample"
   done with a single interpolation, with the exact inverse of step 2's geometry.

Mixed precision: parameters float32, trunks and head compute in ``dtype`` ("bfloat16" on GPU),
the last 1x1 conv and everything after it in float32; outputs are float32.

BatchNorm: ``train=False`` uses running averages; ``train=True`` uses batch statistics (over the
folded ``B * K`` batch) and must be applied with ``mutable=["batch_stats"]``.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Optional

import flax.linen as nn
import jax
import jax.numpy as jnp

from . import densenet, small
from .densenet import HE_NORMAL, batch_norm, conv
from .rotation import rotate, sample_bilinear, source_coords

IMAGENET_MEAN = (0.485, 0.456, 0.406)
IMAGENET_STD = (0.229, 0.224, 0.225)
HEIGHT_MEAN = 0.01  # m, VPG's depth normalisation: (h - 0.01) / 0.03
HEIGHT_STD = 0.03


# ----------------------------------------------------------------------------- helpers


@dataclasses.dataclass(frozen=True)
class TrunkGeometry:
    """Output cell ``k`` of a trunk is centred on input pixel ``stride * k + offset``."""

    stride: int
    offset: float
    channels: int


def trunk_geometry(trunk: str, small_width: int = 32) -> TrunkGeometry:
    if trunk == "densenet121":
        return TrunkGeometry(densenet.STRIDE, densenet.OFFSET, densenet.OUT_CHANNELS)
    if trunk == "small":
        return TrunkGeometry(small.STRIDE, small.OFFSET, small.out_channels(small_width))
    raise ValueError(f"trunk must be 'densenet121' or 'small', got {trunk!r}")


def make_trunk(trunk: str, small_width: int, dtype, name: Optional[str] = None,
               axis_name: Optional[str] = None) -> nn.Module:
    """A trunk module ``(N, P, P, 3) -> (N, P / s, P / s, channels)``; ``axis_name``: its
    BatchNorm statistics in train mode are averaged over that mapped axis (``densenet.batch_norm``)."""
    if trunk == "densenet121":
        return densenet.DenseNet121(dtype=dtype, axis_name=axis_name, name=name)
    if trunk == "small":
        return small.SmallTrunk(width=small_width, dtype=dtype, axis_name=axis_name, name=name)
    raise ValueError(f"trunk must be 'densenet121' or 'small', got {trunk!r}")


def padded_size(size: int, stride: int, rotations: bool = True) -> int:
    """Side of the padded square: ``ceil(size * sqrt 2)`` (or ``size`` without rotations)
    rounded up to a multiple of ``stride``.  224 -> 320 (stride 8 or 32); 32 -> 48 / 64."""
    side = math.ceil(size * math.sqrt(2.0) - 1e-9) if rotations else size
    return -(-side // stride) * stride


def rotation_angles(indices: jax.Array, n_rotations: int, half_turn: bool = False) -> jax.Array:
    """Closing-axis angle ``theta = r * 2 pi / n_rotations`` (radians) of rotation index ``r``;
    ``r * pi / n_rotations`` with ``half_turn`` (``config.Grasp.rotation_step``)."""
    return jnp.asarray(indices, jnp.float32) * ((math.pi if half_turn else 2.0 * math.pi) / n_rotations)


def normalise_colour(colour: jax.Array) -> jax.Array:
    """``(..., 3)`` in 0..255 -> ``(..., 3)`` float32, ``(c / 255 - mean) / std`` (ImageNet)."""
    mean = jnp.asarray(IMAGENET_MEAN, jnp.float32)
    std = jnp.asarray(IMAGENET_STD, jnp.float32)
    return (colour.astype(jnp.float32) / 255.0 - mean) / std


def normalise_height(height: jax.Array) -> jax.Array:
    """``(...)`` metres -> ``(..., 3)`` float32, ``(h - 0.01) / 0.03`` cloned to 3 channels."""
    h = (height.astype(jnp.float32) - HEIGHT_MEAN) / HEIGHT_STD
    return jnp.repeat(h[..., None], 3, axis=-1)


def _pad_offsets(h: int, w: int, p: int) -> tuple[int, int]:
    return (p - h) // 2, (p - w) // 2


def pad_inputs(colour: jax.Array, height: jax.Array, p: int) -> jax.Array:
    """Stack and zero-pad to a centred ``P x P`` square.

    Args:
      colour: ``(B, H, W, 3)`` 0..255 (uint8 or float); height: ``(B, H, W)`` metres.
    Returns:
      ``(B, P, P, 4)`` float32: channels 0..2 colour (0..255), channel 3 height (m).
    """
    _, h, w = height.shape
    top, left = _pad_offsets(h, w, p)
    raw = jnp.concatenate([colour.astype(jnp.float32), height[..., None].astype(jnp.float32)], -1)
    return jnp.pad(raw, ((0, 0), (top, p - h - top), (left, p - w - left), (0, 0)))


def rotated_inputs(padded: jax.Array, theta: jax.Array) -> jax.Array:
    """What GDNet's trunks see, before normalisation.

    Args:
      padded: ``(B, P, P, C)`` from ``pad_inputs``.
      theta: ``(B, K)`` closing-axis angles (radians) of the rotations to evaluate.
    Returns:
      ``(B * K, P, P, C)``: copy ``b * K + k`` is ``padded[b]`` with its content turned by
      ``-theta[b, k]``, so the closing axis ``theta[b, k]`` lies along the horizontal (+col) axis.
    """
    b, k = theta.shape
    folded = jnp.broadcast_to(padded[:, None], (b, k) + padded.shape[1:]).reshape((b * k,) + padded.shape[1:])
    return rotate(folded, -theta.reshape(-1))


def coarse_to_heightmap(coarse: jax.Array, theta: Optional[jax.Array], p: int, h: int, w: int,
                        geometry: TrunkGeometry) -> jax.Array:
    """Rotate back, bilinearly upsample and crop coarse Q maps in one interpolation.

    Args:
      coarse: ``(N, P / s, P / s)`` maps computed on inputs rotated by ``-theta``.
      theta: ``(N,)`` angles given to ``rotated_inputs`` (None: no rotation).
      p: padded side; h, w: heightmap size (centred in the padded square as in ``pad_inputs``).
    Returns:
      ``(N, H, W)`` float32 in heightmap coordinates.
    """
    top, left = _pad_offsets(h, w, p)
    coarse = coarse.astype(jnp.float32)

    def one(cmap, angle):
        if angle is None:
            rows = jnp.broadcast_to(jnp.arange(h, dtype=jnp.float32)[:, None] + top, (h, w))
            cols = jnp.broadcast_to(jnp.arange(w, dtype=jnp.float32)[None, :] + left, (h, w))
        else:  # the point of the rotated input that heightmap pixel q came from: R(-theta)(q-c)+c
            rows, cols = source_coords(p, p, angle)
            rows, cols = rows[top:top + h, left:left + w], cols[top:top + h, left:left + w]
        r = (rows - geometry.offset) / geometry.stride
        c = (cols - geometry.offset) / geometry.stride
        return sample_bilinear(cmap[..., None], r, c, mode="clamp")[..., 0]

    if theta is None:
        return jax.vmap(lambda m: one(m, None))(coarse)
    return jax.vmap(one)(coarse, theta)


def count_params(tree) -> int:
    """Total number of array elements in a pytree (e.g. ``variables["params"]``)."""
    return sum(int(x.size) for x in jax.tree_util.tree_leaves(tree))


# ----------------------------------------------------------------------------- modules


class QHead(nn.Module):
    """BN-ReLU-1x1 conv (no bias)-BN-ReLU-1x1 conv -> ``(N, h, w, C) -> (N, h, w)`` float32."""

    channels: int = 64
    dtype: jnp.dtype = jnp.float32
    axis_name: Optional[str] = None  # BatchNorm's (``densenet.batch_norm``)

    @nn.compact
    def __call__(self, x: jax.Array, train: bool) -> jax.Array:
        x = nn.relu(batch_norm("norm0", train, self.dtype, self.axis_name)(x))
        x = conv(self.channels, 1, "conv0", self.dtype)(x)
        x = nn.relu(batch_norm("norm1", train, self.dtype, self.axis_name)(x))
        q = nn.Conv(1, (1, 1), use_bias=True, dtype=jnp.float32, param_dtype=jnp.float32,
                    kernel_init=HE_NORMAL, name="conv1")(x.astype(jnp.float32))
        return q[..., 0]


class _TwoStream(nn.Module):
    """Shared body: colour trunk + depth trunk + head.  Variables: ``colour_trunk``,
    ``depth_trunk``, ``head`` (in ``params`` and ``batch_stats``)."""

    trunk: str = "densenet121"
    small_width: int = 32
    head_channels: int = 64
    dtype: str = "float32"
    # Data-parallel training: train-mode BatchNorm statistics averaged over this mapped axis
    # (``vags_jax.parallel``), so that a batch split over devices is normalised as a whole.
    axis_name: Optional[str] = None

    def setup(self):
        dt = jnp.dtype(self.dtype)
        self.colour_trunk = make_trunk(self.trunk, self.small_width, dt, axis_name=self.axis_name)
        self.depth_trunk = make_trunk(self.trunk, self.small_width, dt, axis_name=self.axis_name)
        self.head = QHead(self.head_channels, dt, self.axis_name)

    @property
    def geometry(self) -> TrunkGeometry:
        return trunk_geometry(self.trunk, self.small_width)

    def coarse_q(self, raw: jax.Array, train: bool) -> jax.Array:
        """``(N, P, P, 4)`` raw (colour 0..255, height m) -> ``(N, P / s, P / s)`` float32."""
        dt = jnp.dtype(self.dtype)
        colour = normalise_colour(raw[..., :3]).astype(dt)
        depth = normalise_height(raw[..., 3]).astype(dt)
        feats = jnp.concatenate([self.colour_trunk(colour, train), self.depth_trunk(depth, train)], -1)
        return self.head(feats, train)


class GDNet(_TwoStream):
    """Grasp Q-network over ``n_rotations`` gripper rotations (module docstring for details)."""

    n_rotations: int = 16
    half_turn: bool = False  # the rotations span half a turn (``config.Grasp.half_turn``)

    def __call__(self, colour: jax.Array, height: jax.Array, train: bool = False,
                 rotations: Optional[jax.Array] = None) -> jax.Array:
        """Q-values of grasps at every heightmap pixel and rotation.

        Args:
          colour: ``(B, H, W, 3)`` uint8 (or float 0..255) colour heightmap.
          height: ``(B, H, W)`` float32 height heightmap, metres above the table.
          train: BatchNorm mode (``True`` needs ``mutable=["batch_stats"]``).
          rotations: None for all ``n_rotations``; or int indices ``(K,)`` (same for every
            sample) or ``(B, K)`` (per sample, e.g. ``(B, 1)`` for the executed rotation when
            training, which costs ``1 / n_rotations`` of the full evaluation).  May be traced.
        Returns:
          ``(B, K, H, W)`` float32, ``K = n_rotations`` when ``rotations`` is None; entry
          ``[b, k, row, col]`` is the Q-value of closing along angle ``theta(rotations[b, k])``
          centred at ``(row, col)``.
        """
        b, h, w = height.shape
        if rotations is None:
            idx = jnp.broadcast_to(jnp.arange(self.n_rotations, dtype=jnp.int32), (b, self.n_rotations))
        else:
            idx = jnp.asarray(rotations, jnp.int32)
            if idx.ndim == 1:
                idx = jnp.broadcast_to(idx, (b, idx.shape[0]))
            if idx.ndim != 2 or idx.shape[0] != b:
                raise ValueError(f"GDNet: rotations must be (K,) or (B={b}, K) ints, got shape {idx.shape}")
        k = idx.shape[1]
        theta = rotation_angles(idx, self.n_rotations, self.half_turn)  # (B, K)
        p = padded_size(max(h, w), self.geometry.stride, rotations=True)
        x = rotated_inputs(pad_inputs(colour, height, p), theta)  # (B*K, P, P, 4)
        coarse = self.coarse_q(x, train)  # (B*K, P/s, P/s)
        q = coarse_to_heightmap(coarse, theta.reshape(-1), p, h, w, self.geometry)
        return q.reshape(b, k, h, w)


class VANet(_TwoStream):
    """Viewpoint Q-network: the same two-stream design without rotations."""

    def __call__(self, colour: jax.Array, height: jax.Array, train: bool = False) -> jax.Array:
        """Args: colour ``(B, H, W, 3)`` uint8, height ``(B, H, W)`` float32 (m).
        Returns: ``(B, H, W)`` float32 Q-values of moving the camera above each pixel."""
        b, h, w = height.shape
        p = padded_size(max(h, w), self.geometry.stride, rotations=False)
        coarse = self.coarse_q(pad_inputs(colour, height, p), train)
        return coarse_to_heightmap(coarse, None, p, h, w, self.geometry)


# ----------------------------------------------------------------------------- factories


def make_qnet(net_cfg, kind: str = "gdnet", axis_name: Optional[str] = None) -> nn.Module:
    """Build GDNet (``kind="gdnet"``) or VANet (``kind="vanet"``) from a ``config.Net``;
    ``axis_name``: the data-parallel axis its train-mode BatchNorm statistics are averaged over
    (None: one device)."""
    common = dict(trunk=net_cfg.trunk, small_width=net_cfg.small_width,
                  head_channels=net_cfg.head_channels, dtype=net_cfg.dtype, axis_name=axis_name)
    if kind == "gdnet":
        return GDNet(n_rotations=net_cfg.n_rotations, half_turn=net_cfg.half_turn, **common)
    if kind == "vanet":
        return VANet(**common)
    raise ValueError(f"make_qnet: kind must be 'gdnet' or 'vanet', got {kind!r}")


def nbv_net(net_cfg):
    """The NBV baseline's network config from a ``config.Net``: VANet's two-stream design on the
    small trunk (at ``small_width``), randomly initialised."""
    return dataclasses.replace(net_cfg, trunk="small", init=None)


def init_qnet(key: jax.Array, model: nn.Module, height: int, width: int) -> dict:
    """Initialise ``{"params", "batch_stats"}`` for heightmaps of ``(height, width)``.

    Draws the distributions the modules declare (conv kernels He-normal, std
    ``sqrt(2 / fan_in)`` as torch's ``kaiming_normal_``; BN scale and running var 1; biases and
    running means 0) from ONE normal draw split over the kernels.  ``model.init`` would draw them
    too, but XLA compiles one threefry generator per parameter: tens of seconds on CPU for
    DenseNet-121, against about a second here.  Deterministic in ``key``.
    """
    return init_variables(key, variable_shapes(model, height, width))


def variable_shapes(model: nn.Module, height: int, width: int) -> dict:
    """``jax.ShapeDtypeStruct`` tree of ``model``'s variables (traced, never compiled)."""
    colour = jnp.zeros((1, height, width, 3), jnp.uint8)
    hmap = jnp.zeros((1, height, width), jnp.float32)
    kwargs = {"rotations": jnp.zeros((1,), jnp.int32)} if isinstance(model, GDNet) else {}
    return dict(jax.eval_shape(lambda k: model.init(k, colour, hmap, train=False, **kwargs),
                               jax.random.PRNGKey(0)))


def init_variables(key: jax.Array, shapes) -> dict:
    """Fill a ``ShapeDtypeStruct`` tree of this package's variables (see ``init_qnet``)."""
    leaves, treedef = jax.tree_util.tree_flatten_with_path(shapes)
    names = [str(getattr(path[-1], "key", path[-1])) for path, _ in leaves]
    for (path, _), name in zip(leaves, names):
        if name not in ("kernel", "scale", "var", "bias", "mean"):
            raise ValueError(f"init_variables: no initialiser for {jax.tree_util.keystr(path)}")
    total = sum(math.prod(s.shape) for (_, s), n in zip(leaves, names) if n == "kernel")

    @jax.jit
    def make(k):
        z = jax.random.normal(k, (total,), jnp.float32)
        out, start = [], 0
        for (_, s), name in zip(leaves, names):
            if name == "kernel":
                size = math.prod(s.shape)
                std = math.sqrt(2.0 / math.prod(s.shape[:-1]))
                out.append((z[start:start + size].reshape(s.shape) * std).astype(s.dtype))
                start += size
            else:
                out.append(jnp.full(s.shape, 1.0 if name in ("scale", "var") else 0.0, s.dtype))
        return jax.tree_util.tree_unflatten(treedef, out)

    return dict(make(key))
