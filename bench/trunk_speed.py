#!/usr/bin/env python3
"""How fast the Q-networks' two trunks and head run, and whether another formulation of the same
arithmetic runs faster: the pass that dominates a DQN update (the target network over every
rotation of the next states) and the actor's choice (bench/RESULTS.md, "Where the update's
time goes").

    python bench/trunk_speed.py --out runs/trunk_speed.json            # gpu preset's GDNet
    python bench/trunk_speed.py --px 32 --width 8 --batches 8 --reps 1  # CPU smoke run

Every formulation computes ``coarse_q`` (vags_jax.nets.qnet, steps 3-4: normalisation, colour and
depth trunks, head) in eval mode on the same ``(N, P, P, 4)`` rotated inputs, from the same
variables, and each is checked against the module's output:

* ``modules``: the code GDNet runs (``GDNet.coarse_q``);
* ``grouped``: the small trunk's colour and depth convolutions as one convolution with two
  feature groups per layer (kernels stacked along the output channels; BatchNorm per channel),
  so each layer is one kernel launch over 6 -> 2 x 32 -> ... channels;
* ``grouped_s2d``: as ``grouped``, with the first 4x4 stride-2 convolution (3 input channels a
  stream) rewritten as a 2x2 stride-1 convolution over the 2 x 2 space-to-depth of its padded
  input (12 channels a stream): the same sums, in fewer, wider taps;
* ``streams`` and ``streams_s2d``: each stream's layers as plain ``lax`` convolutions, without and
  with that first layer; ``streams_s2d_folded``: with eval-mode BatchNorm folded into each
  kernel and a bias (conv + bias + ReLU a layer); ``streams_s2d_folded_depth1``: also the depth
  stream's first layer over the one height channel, with its kernel summed over the three input
  channels that ``normalise_height`` fills with copies of it (4 space-to-depth channels, not 12).

Then one stream's layers 0..k alone (k = 0..3, with and without space-to-depth): where a pass
goes, layer by layer.

Model FLOPs as ``flop_count`` counts them; MFU against a bf16 matmul measured here.  Needs only
jax and flax (no physics).  Timings mean something on a GPU only.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from flop_count import forward_flops  # noqa: E402
from timing import matmul_peak, timed  # noqa: E402

from vags_jax import config as C  # noqa: E402
from vags_jax.nets import init_qnet, make_qnet, normalise_colour, normalise_height, padded_size  # noqa: E402
from vags_jax.nets.small import folded_batch_norm  # noqa: E402


def _bn(v, trunk: str, layer: str):
    """``(mul, shift)`` of one trunk's eval-mode BatchNorm ``layer`` (``folded_batch_norm``)."""
    return folded_batch_norm({"params": v["params"][trunk][layer], "batch_stats": v["batch_stats"][trunk][layer]})


def _bn_relu(x, mul, shift):
    """Eval-mode BatchNorm then ReLU, per channel (the last axis)."""
    return jax.nn.relu(x * mul.astype(x.dtype) + shift.astype(x.dtype))


def _stacked(v, layer: str, norm: bool = False):
    """The colour and depth trunks' ``layer`` joined along the output channels: the conv kernel
    ``(kh, kw, cin, 2 cout)`` (feature group 0 = colour), or BatchNorm's ``(mul, shift)``."""
    trunks = ("colour_trunk", "depth_trunk")
    if not norm:
        return jnp.concatenate([v["params"][t][layer]["kernel"] for t in trunks], -1)
    (m0, s0), (m1, s1) = (_bn(v, t, layer) for t in trunks)
    return jnp.concatenate([m0, m1]), jnp.concatenate([s0, s1])


def _conv(x, kernel, stride: int, pad: int, groups: int = 2):
    return jax.lax.conv_general_dilated(x, kernel.astype(x.dtype), (stride, stride), ((pad, pad), (pad, pad)),
                                        dimension_numbers=("NHWC", "HWIO", "NHWC"), feature_group_count=groups)


def _space_to_depth_first_conv(x, kernel, groups: int = 2):
    """4x4 / 2 pad 1 conv of ``x (N, P, P, groups * c)`` as a 2x2 / 1 conv of the padded input's
    2 x 2 space-to-depth (``vags_jax.nets.small.StridedConv``'s, with feature groups): tap
    ``(2a + r, 2b + s)`` of the kernel reads input block ``(a, b)`` at offset ``(r, s)``.
    Channels stay grouped per stream: (group, r, s, c)."""
    n, p, _, cg = x.shape
    c = cg // groups
    xp = jnp.pad(x, ((0, 0), (1, 1), (1, 1), (0, 0)))
    m = (p + 2) // 2
    xs = xp.reshape(n, m, 2, m, 2, groups, c).transpose(0, 1, 3, 5, 2, 4, 6).reshape(n, m, m, groups * 4 * c)
    cout = kernel.shape[-1]
    k = kernel.reshape(2, 2, 2, 2, c, cout).transpose(0, 2, 1, 3, 4, 5).reshape(2, 2, 4 * c, cout)
    return _conv(xs, k, 1, 0, groups)


def _stream(v, trunk: str, x, s2d: bool, upto: int = 4, fold: bool = False):
    """One trunk's layers ``0 .. upto - 1`` as plain convolutions (``s2d``: the first by
    space-to-depth; ``fold``: eval-mode BatchNorm folded into the kernel and a bias, so that
    each layer is conv + bias + ReLU).  An ``x`` of one channel where the first kernel takes
    more stands for that many copies of it: the kernel is summed over its input channels."""
    p = v["params"][trunk]
    for i in range(min(upto, 3)):
        mul, shift = _bn(v, trunk, f"norm{i}")
        k = p[f"conv{i}"]["kernel"] * mul if fold else p[f"conv{i}"]["kernel"]
        if i == 0 and x.shape[-1] == 1 < k.shape[2]:
            k = k.sum(axis=2, keepdims=True)
        x = _space_to_depth_first_conv(x, k, 1) if (s2d and i == 0) else _conv(x, k, 2, 1, 1)
        x = jax.nn.relu(x + shift.astype(x.dtype)) if fold else _bn_relu(x, mul, shift)
    return _conv(x, p["conv3"]["kernel"], 1, 1, 1) if upto > 3 else x


def streams_coarse_q(net, v, raw, s2d: bool = False, fold: bool = False, depth1: bool = False):
    """``coarse_q`` with each stream's layers as plain convolutions (``s2d``: first layer by
    space-to-depth; ``fold``: BatchNorm folded, ``_stream``; ``depth1``: the depth stream's
    first layer over the one height channel)."""
    dt = jnp.dtype(net.dtype)
    depth = normalise_height(raw[..., 3])
    depth = depth[..., :1] if depth1 else depth
    feats = jnp.concatenate([_stream(v, "colour_trunk", normalise_colour(raw[..., :3]).astype(dt), s2d, fold=fold),
                             _stream(v, "depth_trunk", depth.astype(dt), s2d, fold=fold)], -1)
    return net.apply(v, feats, False, method=lambda m, f, t: m.head(f, t))


def grouped_coarse_q(net, v, raw, s2d: bool = False):
    """``coarse_q`` of the small-trunk two-stream net with grouped convolutions (module docstring)."""
    dt = jnp.dtype(net.dtype)
    x = jnp.concatenate([normalise_colour(raw[..., :3]), normalise_height(raw[..., 3])], -1).astype(dt)
    for i in range(3):
        x = _space_to_depth_first_conv(x, _stacked(v, "conv0")) if (s2d and i == 0) else \
            _conv(x, _stacked(v, f"conv{i}"), 2, 1)
        x = _bn_relu(x, *_stacked(v, f"norm{i}", norm=True))
    feats = _conv(x, _stacked(v, "conv3"), 1, 1)  # (N, P/8, P/8, 8 w) = [colour, depth] features
    return net.apply(v, feats, False, method=lambda m, f, t: m.head(f, t))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--config", default="gpu", help="preset whose net section is measured (default gpu)")
    p.add_argument("--px", type=int, default=None, help="heightmap side (default: the preset's)")
    p.add_argument("--width", type=int, default=None, help="small trunk width (default: the preset's)")
    p.add_argument("--batches", default="1024,2048", help="images per pass (comma-separated)")
    p.add_argument("--reps", type=int, default=10)
    p.add_argument("--out", default=None)
    args = p.parse_args(argv)
    cfg = C.preset(args.config)
    net_cfg = C.replace(cfg, **({"net.small_width": args.width} if args.width else {})).net
    if net_cfg.trunk != "small":
        raise SystemExit("trunk_speed.py measures the small trunk's formulations; use a preset with net.trunk=small")
    px = args.px or cfg.workspace.heightmap_px
    net = make_qnet(net_cfg, "gdnet")
    v = init_qnet(jax.random.PRNGKey(0), net, px, px)
    # Running statistics away from (0, 1), so that the check covers BatchNorm's arithmetic.
    v["batch_stats"] = jax.tree.map(lambda x: x + 0.1 * jax.random.uniform(jax.random.PRNGKey(1), x.shape),
                                    v["batch_stats"])
    side = padded_size(px, 8)
    on_gpu = jax.devices()[0].platform == "gpu"
    peak = matmul_peak(8192 if on_gpu else 512)
    print(f"device: {jax.devices()[0].device_kind}; small trunk width {net_cfg.small_width}, {net_cfg.dtype}; "
          f"inputs {side} x {side}; bf16 matmul peak {peak / 1e12:.1f} TFLOP/s", flush=True)
    forms = {"modules": lambda v, x: net.apply(v, x, False, method=net.coarse_q),
             "grouped": lambda v, x: grouped_coarse_q(net, v, x),
             "grouped_s2d": lambda v, x: grouped_coarse_q(net, v, x, s2d=True),
             "streams": lambda v, x: streams_coarse_q(net, v, x),
             "streams_s2d": lambda v, x: streams_coarse_q(net, v, x, s2d=True),
             "streams_s2d_folded": lambda v, x: streams_coarse_q(net, v, x, s2d=True, fold=True),
             "streams_s2d_folded_depth1": lambda v, x: streams_coarse_q(net, v, x, s2d=True, fold=True, depth1=True)}
    rows = []
    for n in [int(b) for b in args.batches.split(",") if b]:
        k = jax.random.split(jax.random.PRNGKey(n), 2)
        raw = jnp.concatenate([jax.random.uniform(k[0], (n, side, side, 3), maxval=255.0),
                               jax.random.uniform(k[1], (n, side, side, 1), maxval=0.1)], -1)
        ref = None
        for name, fn in forms.items():
            jf = jax.jit(fn)
            dt, out = timed(jf, v, raw, repeats=args.reps)
            out = np.asarray(out, np.float32)
            ref = out if ref is None else ref
            err = float(np.abs(out - ref).max() / max(np.abs(ref).max(), 1e-9))
            flops = forward_flops(fn, v, raw)
            row = {"form": name, "images": n, "s": dt, "ms_per_1024_images": 1e3 * dt * 1024 / n, "flops": flops,
                   "flops_per_s": flops / dt, "mfu": flops / dt / peak, "max_rel_diff_to_modules": err}
            rows.append(row)
            print(f"  {name:12s} {n:5d} images: {dt * 1e3:8.2f} ms, {row['ms_per_1024_images']:7.2f} ms per 1024, "
                  f"{flops / dt / 1e12:6.1f} TFLOP/s = {100 * row['mfu']:4.1f} % MFU; "
                  f"max |diff| / max |Q| to modules {err:.1e}", flush=True)
    n = int(args.batches.split(",")[0])
    x = normalise_colour(jax.random.uniform(jax.random.PRNGKey(5), (n, side, side, 3), maxval=255.0)).astype(
        jnp.dtype(net.dtype))
    layers = []
    for upto in range(1, 5):  # one stream, layers 0 .. upto - 1: each layer's time is the increment
        for s2d, fold in ((False, False), (True, False), (True, True)):
            dt, _ = timed(jax.jit(lambda v, x: _stream(v, "colour_trunk", x, s2d, upto, fold)), v, x,
                          repeats=args.reps)
            layers.append({"layers": upto, "s2d": s2d, "fold": fold, "images": n, "s": dt})
            print(f"  one stream, layers 0-{upto - 1}{' (first by space-to-depth)' if s2d else ''}"
                  f"{' (BatchNorm folded)' if fold else ''}: {dt * 1e3:.2f} ms for {n} images", flush=True)
    if args.out:
        os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
        with open(args.out, "w") as f:
            json.dump({"device": jax.devices()[0].device_kind, "net": net_cfg.__dict__ | {}, "heightmap_px": px,
                       "padded": side, "matmul_peak_flops_per_s": peak, "rows": rows, "one_stream_layers": layers,
                       "date": time.strftime("%Y-%m-%d")}, f, indent=2, default=str)
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
