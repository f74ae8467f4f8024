"""GG-CNN training pieces: loss, Adam update step, rotation / zoom augmentation (pure JAX).

Training data are pairs of a preprocessed depth image ``x`` ``(B, H, W)`` (output of
``ggcnn_process.preprocess_depth``) and label maps ``GraspMaps`` ``(B, H, W)`` (from
``ggcnn_labels.label_maps``), with an optional per-pixel loss weight ``(B, H, W)``
(``ggcnn_labels.labels_and_weight``: tried pixels 1, untried ones less).  The loss is GG-CNN's,
the sum of the four mean squared errors (quality, cos 2theta, sin 2theta, width), each squared
error multiplied by the weight when one is given; optimised with Adam.

Augmentation (as GG-CNN's training): each sample is rotated about the image centre by a random
angle (``GGCNNConfig.rotation``: quarter turns, any angle, or none) and zoomed by a factor ``z``
drawn from ``GGCNNConfig.zoom_range`` (the centred ``z H x z W`` region is resized up to
``H x W``).  Output pixel ``p`` reads the source at ``c + z R(-phi) (p - c)``, ``c`` the image
centre and ``R(phi)`` the turn from +u towards +v (``vags_jax.nets.rotation``), so the
content turns by ``phi`` and grows by ``1 / z``.  Depth is sampled bilinearly (edges extended);
labels by nearest pixel (0 outside), then their values follow the geometry: theta becomes
``theta + phi`` (cos 2theta, sin 2theta rotated by ``2 phi``) and the opening grows by ``1 / z``
(width = min(width / z, 1), GG-CNN's clip at 150 px).  The weight map is resampled like the
labels (0 outside the source image: no data there).
"""
from __future__ import annotations

import functools
import math
from typing import Callable, Optional

import flax.struct
import jax
import jax.numpy as jnp
import optax

from vags_jax.nets.ggcnn import GGCNN, GGCNNConfig, GraspMaps, init_ggcnn
from vags_jax.nets.rotation import sample_bilinear


def _check(cond: bool, msg: str) -> None:
    if not cond:
        raise ValueError(msg)


# ----------------------------------------------------------------------------- loss


def ggcnn_loss(params, model: GGCNN, x: jax.Array, labels: GraspMaps, weight: Optional[jax.Array] = None):
    """GG-CNN loss: sum of the four per-map (weighted) MSEs.

    Args:
      params: ``{"params": ...}`` of ``model``.
      x: ``(B, H, W)`` preprocessed depth.
      labels: GraspMaps ``(B, H, W)``.
      weight: ``(B, H, W)`` per-pixel weight of the squared errors, or None (all 1).
    Returns:
      ``(loss scalar, {"quality", "cos", "sin", "width"} scalar MSEs)``.
    """
    pred = model.apply(params, x)
    _check(
        pred.quality.shape == tuple(jnp.shape(labels.quality)),
        f"ggcnn_loss: labels must be (B, H, W) = {pred.quality.shape} like the input, "
        f"got {tuple(jnp.shape(labels.quality))}",
    )
    w = 1.0 if weight is None else weight
    terms = {
        name: jnp.mean(w * (getattr(pred, name) - getattr(labels, name)) ** 2)
        for name in ("quality", "cos", "sin", "width")
    }
    return sum(terms.values()), terms


# ----------------------------------------------------------------------------- augmentation


def sample_augmentation(key: jax.Array, batch: int, cfg: GGCNNConfig = GGCNNConfig()):
    """Random rotation ``(B,)`` radians and zoom ``(B,)`` factors for one batch.

    Rotation: ``"quarter"`` one of 0, pi/2, pi, 3pi/2; ``"any"`` uniform in [0, 2pi);
    ``"none"`` 0.  Zoom: uniform in ``cfg.zoom_range``.
    """
    k_rot, k_zoom = jax.random.split(key)
    if cfg.rotation == "quarter":
        angle = jax.random.randint(k_rot, (batch,), 0, 4).astype(jnp.float32) * (math.pi / 2)
    elif cfg.rotation == "any":
        angle = jax.random.uniform(k_rot, (batch,), minval=0.0, maxval=2 * math.pi)
    else:
        angle = jnp.zeros((batch,), jnp.float32)
    lo, hi = cfg.zoom_range
    zoom = jax.random.uniform(k_zoom, (batch,), minval=lo, maxval=hi)
    return angle, zoom


def _snap(x: jax.Array) -> jax.Array:
    """cos / sin of a quarter turn to exact 0 / +-1 (so quarter turns resample exactly)."""
    r = jnp.round(x)
    return jnp.where(jnp.abs(x - r) < 1e-6, r, x)


def augment_sample(x: jax.Array, labels: GraspMaps, angle, zoom, weight: Optional[jax.Array] = None):
    """Rotate one sample by ``angle`` and zoom it by ``zoom`` (module docstring).

    Args:
      x: ``(H, W)`` preprocessed depth; labels: GraspMaps ``(H, W)``; angle, zoom: scalars;
      weight: ``(H, W)`` loss weight or None.
    Returns:
      ``(x', labels')`` of the same shapes, and ``weight'`` third when ``weight`` is given.
    """
    h, w = x.shape
    cy, cx = (h - 1) / 2.0, (w - 1) / 2.0
    c, s = _snap(jnp.cos(angle)), _snap(jnp.sin(angle))
    du = jnp.arange(w, dtype=jnp.float32)[None, :] - cx
    dv = jnp.arange(h, dtype=jnp.float32)[:, None] - cy
    # R(-phi) (du, dv) = (c du + s dv, -s du + c dv), scaled by zoom.
    src_u = zoom * (c * du + s * dv) + cx
    src_v = zoom * (-s * du + c * dv) + cy
    x_out = sample_bilinear(x[..., None], src_v, src_u, "clamp")[..., 0]

    ru, rv = jnp.round(src_u).astype(jnp.int32), jnp.round(src_v).astype(jnp.int32)
    inside = (ru >= 0) & (ru < w) & (rv >= 0) & (rv < h)
    stacked = labels.stack() if weight is None else jnp.concatenate([labels.stack(), weight[..., None]], -1)
    lab = stacked[jnp.clip(rv, 0, h - 1), jnp.clip(ru, 0, w - 1)]
    lab = jnp.where(inside[..., None], lab, 0.0)
    q, cos2, sin2, wid = lab[..., 0], lab[..., 1], lab[..., 2], lab[..., 3]
    c2, s2 = c * c - s * s, 2 * s * c  # cos 2phi, sin 2phi
    out = GraspMaps(
        quality=q,
        cos=cos2 * c2 - sin2 * s2,
        sin=sin2 * c2 + cos2 * s2,
        width=jnp.minimum(wid / zoom, 1.0),
    )
    return (x_out, out) if weight is None else (x_out, out, lab[..., 4])


def augment_batch(key: jax.Array, x: jax.Array, labels: GraspMaps, cfg: GGCNNConfig = GGCNNConfig(),
                  weight: Optional[jax.Array] = None):
    """Augment a batch ``x`` ``(B, H, W)``, labels GraspMaps ``(B, H, W)`` (and the loss weight
    ``(B, H, W)`` when given, returned third): a random rotation and zoom per sample
    (``sample_augmentation``).  Quarter turns need square images."""
    _check(x.ndim == 3, f"augment_batch: x must be (B, H, W), got shape {x.shape}")
    _check(cfg.rotation == "none" or x.shape[1] == x.shape[2],
           f"augment_batch: rotation augmentation needs square images, got {x.shape[1]} x {x.shape[2]}; "
           "set GGCNNConfig.rotation = 'none'")
    angle, zoom = sample_augmentation(key, x.shape[0], cfg)
    if weight is None:
        return jax.vmap(augment_sample)(x, labels, angle, zoom)
    return jax.vmap(augment_sample)(x, labels, angle, zoom, weight)


# ----------------------------------------------------------------------------- training


@flax.struct.dataclass
class GGCNNTrainState:
    """``params`` ``{"params": ...}``, Adam ``opt_state``, ``step`` () int32 updates made."""

    params: dict
    opt_state: optax.OptState
    step: jax.Array


def make_optimizer(cfg: GGCNNConfig = GGCNNConfig()) -> optax.GradientTransformation:
    """Adam at ``cfg.learning_rate`` (GG-CNN: torch's Adam defaults)."""
    return optax.adam(cfg.learning_rate)


def init_train_state(key: jax.Array, cfg: GGCNNConfig = GGCNNConfig(), model: Optional[GGCNN] = None,
                     optimizer: Optional[optax.GradientTransformation] = None) -> GGCNNTrainState:
    """Fresh parameters (``init_ggcnn``) and optimiser state."""
    optimizer = make_optimizer(cfg) if optimizer is None else optimizer
    params = init_ggcnn(key, model, size=12)
    return GGCNNTrainState(params, optimizer.init(params), jnp.zeros((), jnp.int32))


def train_step(state: GGCNNTrainState, key: jax.Array, x: jax.Array, labels: GraspMaps,
               weight: Optional[jax.Array] = None, *, model: GGCNN, optimizer: optax.GradientTransformation,
               cfg: GGCNNConfig, augment: bool = True):
    """One Adam update on a batch (augmented with ``key`` when ``augment``).

    Args:
      state: GGCNNTrainState; key: PRNG key; x: ``(B, H, W)``; labels: GraspMaps ``(B, H, W)``;
      weight: ``(B, H, W)`` loss weight or None (``ggcnn_loss``).
    Returns:
      ``(new state, metrics)`` with metrics ``{"loss", "quality", "cos", "sin", "width"}``
      scalars, the loss before the update.
    """
    if augment and weight is None:
        x, labels = augment_batch(key, x, labels, cfg)
    elif augment:
        x, labels, weight = augment_batch(key, x, labels, cfg, weight)
    (loss, terms), grads = jax.value_and_grad(ggcnn_loss, has_aux=True)(state.params, model, x, labels, weight)
    updates, opt_state = optimizer.update(grads, state.opt_state, state.params)
    params = optax.apply_updates(state.params, updates)
    return GGCNNTrainState(params, opt_state, state.step + 1), {"loss": loss, **terms}


def make_train_step(cfg: GGCNNConfig = GGCNNConfig(), model: Optional[GGCNN] = None,
                    optimizer: Optional[optax.GradientTransformation] = None,
                    augment: bool = True) -> Callable:
    """Jitted ``step(state, key, x, labels[, weight]) -> (state, metrics)`` (see ``train_step``)."""
    model = GGCNN() if model is None else model
    optimizer = make_optimizer(cfg) if optimizer is None else optimizer
    return jax.jit(functools.partial(train_step, model=model, optimizer=optimizer, cfg=cfg, augment=augment))
