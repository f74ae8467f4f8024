#!/usr/bin/env python3
"""How fast one DenseNet-121 trunk runs in eval mode (the pass the target network and the actor
run over every rotation: most of a `paper`-preset update, bench/RESULTS.md), and whether another
formulation of the same arithmetic runs faster.

    python bench/densenet_speed.py --out runs/densenet_speed.json        # 1,024 images of 320 x 320
    python bench/densenet_speed.py --px 64 --batches 4 --reps 1           # CPU smoke run

Every formulation computes ``DenseNet121.apply(v, x, train=False)`` on the same ``(N, P, P, 3)``
inputs from the same variables, and is checked against the module's output:

* ``module``: the code GDNet runs (``vags_jax.nets.densenet.DenseNet121``);
* ``folded``: plain ``lax`` convolutions, with the two BatchNorms that follow a convolution
  (``norm0`` after the stem, ``norm2`` after each dense layer's 1x1 convolution) folded into its
  kernel and a bias, so those layers are conv + bias + ReLU; the BatchNorms that come before a
  convolution (``norm1``, the transitions' ``norm``) stay a scale, shift and ReLU of its input;
* ``folded_buffer``: as ``folded``, with each dense block's features written into one buffer of
  the block's final width (a static ``dynamic_update_slice`` a layer) instead of concatenated
  anew after every layer;
* ``folded_s2d``: as ``folded``, with the stem's 7x7 / 2 convolution over 3 channels run as a
  4x4 / 1 convolution over the 2 x 2 space-to-depth of its padded input (12 channels; the kernel
  padded to 8 x 8 with zeros): the same sums in fewer, wider taps;
* ``folded_s2d_dot``: as ``folded_s2d``, with every 1x1 convolution (each dense layer's
  ``conv1``, each transition's ``conv``) a matrix product over the channel axis (``dot_general``)
  and the BatchNorm affine + ReLU before it written as its operand: whether XLA fuses that
  elementwise prologue into a GEMM (it does not into a cuDNN convolution);
* ``folded_s2d_poolfirst``: as ``folded_s2d``, each transition BN-ReLU, 2x2 / 2 average pool,
  then the 1x1 convolution: the same function (a bias-free 1x1 conv and the average pool are
  both linear, one per pixel, one per channel: they commute), the conv over a quarter of the
  pixels, so fewer executed FLOPs than the module's (``module_flops`` below);
* ``folded_s2d_pooldot``: both of the above (whether their gains add up);
* ``upto_stem``, ``upto_block1``, ``upto_trans1``, ``upto_block2``, ``upto_trans2``,
  ``upto_block3``, ``upto_trans3``, ``upto_block4``: ``folded_s2d`` cut after that stage
  (``upto_block4``: the whole pass, ``norm5`` included), each checked against the module's own
  result at the same cut (``module_cuts``, computed once, not timed): cumulative times, whose
  differences are each stage's time;
* ``stem`` and ``stem_s2d``: the stem alone (conv0, norm0 folded, ReLU, max pool), each way,
  checked against the plain stem: its share of a pass.

``flops``: the form's executed FLOPs as ``flop_count`` counts them (the space-to-depth stem as the
7 x 7 conv it computes), ``mfu`` from them; ``module_flops``: the module's count for the same
result (the whole pass, or its stages up to the cut), ``mfu_of_module_flops`` from them: the same
model's FLOPs in the form's time (differs from ``mfu`` for the pool-first forms only).  MFU
against a bf16 matmul measured here.  Needs only jax and flax (no physics).  Timings mean
something on a GPU only.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time

import flax.linen as nn
import jax
import jax.numpy as jnp
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from flop_count import forward_flops  # noqa: E402
from timing import matmul_peak, timed  # noqa: E402

from vags_jax.nets import densenet, init_variables  # noqa: E402
from vags_jax.nets.densenet import folded_batch_norm  # noqa: E402


def _conv(x, kernel, stride: int = 1, pad: int = 0):
    return jax.lax.conv_general_dilated(x, kernel.astype(x.dtype), (stride, stride), ((pad, pad), (pad, pad)),
                                        dimension_numbers=("NHWC", "HWIO", "NHWC"))


def _bn(v, *path):
    """``(mul, shift)`` of the eval-mode BatchNorm at ``path`` (``folded_batch_norm``)."""
    p, s = v["params"], v["batch_stats"]
    for k in path:
        p, s = p[k], s[k]
    return folded_batch_norm({"params": p, "batch_stats": s})


def _affine_relu(x, mul, shift):
    return jax.nn.relu(x * mul.astype(x.dtype) + shift.astype(x.dtype))


def _conv_bn_relu(x, kernel, mul, shift, stride: int = 1, pad: int = 0):
    """conv then an eval-mode BatchNorm then ReLU, the BatchNorm folded: conv + bias + ReLU."""
    return jax.nn.relu(_conv(x, kernel * mul, stride, pad) + shift.astype(x.dtype))


def _stem_s2d(x, kernel, mul, shift):
    """The stem's 7x7 / 2 conv (pad 3) by space-to-depth (``densenet.stride2_conv_by_space_to_depth``),
    BatchNorm folded, ReLU."""
    y = densenet.stride2_conv_by_space_to_depth(x, (kernel * mul).astype(x.dtype), 3)
    return jax.nn.relu(y + shift.astype(x.dtype))


def stem(v, x, dtype, s2d: bool = False):
    """conv0 - norm0 - ReLU - max pool 3x3 / 2 (norm0 folded)."""
    x = x.astype(dtype)
    if s2d:
        x = _stem_s2d(x, v["params"]["conv0"]["kernel"], *_bn(v, "norm0"))
    else:
        x = _conv_bn_relu(x, v["params"]["conv0"]["kernel"], *_bn(v, "norm0"), stride=2, pad=3)
    return jax.lax.reduce_window(x, jnp.array(-jnp.inf, x.dtype), jax.lax.max, (1, 3, 3, 1), (1, 2, 2, 1),
                                 ((0, 0), (1, 1), (1, 1), (0, 0)))


def _pointwise(x, kernel, dot: bool = False):
    """A 1x1 convolution, ``kernel`` ``(1, 1, C, F)``: a ``lax`` convolution, or with ``dot`` a
    matrix product over x's channel axis (result in x's dtype, as the convolution's)."""
    if not dot:
        return _conv(x, kernel)
    return jax.lax.dot_general(x, kernel[0, 0].astype(x.dtype), (((x.ndim - 1,), (0,)), ((), ())))


def _avg_pool2(x):
    """2x2 / 2 average pool (summed in float32)."""
    n, h, w, c = x.shape
    return x.reshape(n, h // 2, 2, w // 2, 2, c).mean(axis=(2, 4), dtype=jnp.float32).astype(x.dtype)


def _dense_layer(v, block: str, i: int, x, dot: bool = False):
    """norm1-ReLU-conv1 (norm2 folded)-ReLU-conv2 3x3; ``dot``: conv1 as a matrix product."""
    name = f"denselayer{i + 1}"
    p = v["params"][block][name]
    y = _affine_relu(x, *_bn(v, block, name, "norm1"))
    mul, shift = _bn(v, block, name, "norm2")
    y = jax.nn.relu(_pointwise(y, p["conv1"]["kernel"] * mul, dot) + shift.astype(y.dtype))
    return _conv(y, p["conv2"]["kernel"], pad=1)


def _transition(v, t: str, x, dot: bool = False, pool_first: bool = False):
    """norm-ReLU-conv 1x1-avgpool 2x2 / 2; ``pool_first``: pool, then the conv (the two commute:
    both linear, the conv bias-free), which then runs over a quarter of the pixels."""
    y = _affine_relu(x, *_bn(v, t, "norm"))
    kernel = v["params"][t]["conv"]["kernel"]
    if pool_first:
        return _pointwise(_avg_pool2(y), kernel, dot)
    return _avg_pool2(_pointwise(y, kernel, dot))


# Where an ``upto_*`` form cuts the pass: after the stem, each dense block, each transition
# (``block4``: the whole pass, norm5 included).
CUTS = ("stem", "block1", "trans1", "block2", "trans2", "block3", "trans3", "block4")
# The module's children each cut follows (block4's result: the module's, after norm5).
_CUT_AFTER = {**{f"denseblock{b}": f"block{b}" for b in (1, 2, 3, 4)}, **{f"transition{b}": f"trans{b}" for b in (1, 2, 3)}}


def folded_forward(v, x, dtype, buffer: bool = False, s2d: bool = False, dot: bool = False,
                   pool_first: bool = False, upto: str = "block4", blocks=densenet.BLOCK_CONFIG):
    """DenseNet-121 eval mode, BatchNorms after convolutions folded (module docstring for the
    options); ``upto``: the result at that cut (``CUTS``); ``blocks``: dense layers per block
    (the module's ``block_config``)."""
    x = stem(v, x, dtype, s2d)
    if upto == "stem":
        return x
    channels = densenet.INIT_FEATURES
    for b, n_layers in enumerate(blocks):
        block = f"denseblock{b + 1}"
        width = channels + n_layers * densenet.GROWTH
        if buffer:
            buf = jnp.zeros(x.shape[:3] + (width,), x.dtype)
            buf = jax.lax.dynamic_update_slice(buf, x, (0, 0, 0, 0))
            for i in range(n_layers):
                c = channels + i * densenet.GROWTH
                y = _dense_layer(v, block, i, buf[..., :c], dot)
                buf = jax.lax.dynamic_update_slice(buf, y, (0, 0, 0, c))
            x = buf
        else:
            for i in range(n_layers):
                x = jnp.concatenate([x, _dense_layer(v, block, i, x, dot)], axis=-1)
        channels = width
        if b != len(blocks) - 1:
            if upto == f"block{b + 1}":
                return x
            x = _transition(v, f"transition{b + 1}", x, dot, pool_first)
            channels //= 2
            if upto == f"trans{b + 1}":
                return x
    mul, shift = _bn(v, "norm5")
    return x * mul.astype(x.dtype) + shift.astype(x.dtype)


def _skipped(module, x):
    """Zeros of the shape a dense block or transition would return for ``x``: its stand-in after
    the cut (neither run nor counted)."""
    n, h, w, c = x.shape
    if isinstance(module, densenet.Transition):
        return jnp.zeros((n, h // 2, w // 2, module.features), x.dtype)
    return jnp.zeros((n, h, w, c + module.n_layers * module.growth), x.dtype)


def module_cuts(net, v, x, last: str = "block4") -> dict:
    """The module's own results at each cut up to ``last`` (``CUTS``), ``{cut: array}``: the stem's
    is denseblock1's input, a block's or transition's its output, ``block4``'s the module's
    output; the blocks and transitions after ``last`` are not run (``_skipped``), so the FLOPs
    of this function are the module's up to ``last``."""
    stop = CUTS.index(last)
    cuts = {}

    def record(next_fun, args, kwargs, context):
        name = context.module.name if context.method_name == "__call__" else None
        if name not in _CUT_AFTER:  # the stem's and the dense layers' modules, norm5
            return next_fun(*args, **kwargs)
        if name == "denseblock1":
            cuts["stem"] = args[0]
        if CUTS.index(_CUT_AFTER[name]) > stop:
            return _skipped(context.module, args[0])
        cuts[_CUT_AFTER[name]] = out = next_fun(*args, **kwargs)
        return out

    with nn.intercept_methods(record):
        cuts["block4"] = net.apply(v, x, False)  # after norm5, not denseblock4's output
    return {c: cuts[c] for c in CUTS[:stop + 1]}


def _cut_of(form: str) -> str:
    """The cut whose module result a form computes: the stem forms the stem, ``upto_*`` theirs,
    the others the whole pass."""
    return "stem" if form.startswith("stem") else form[len("upto_"):] if form.startswith("upto_") else "block4"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--px", type=int, default=320, help="input side (default 320: the paper preset's padded map)")
    p.add_argument("--batches", default="1024", help="images per pass (comma-separated)")
    p.add_argument("--dtype", default="bfloat16")
    p.add_argument("--reps", type=int, default=10)
    p.add_argument("--forms", default="module,folded,folded_buffer",
                   help="comma-separated, module first (the others are checked against it): module, folded, "
                        "folded_buffer, folded_s2d, folded_s2d_dot, folded_s2d_poolfirst, folded_s2d_pooldot, "
                        + ", ".join(f"upto_{c}" for c in CUTS) + " (checked against the module's result at the cut), "
                        "stem, stem_s2d (stem first: checked against it); the module docstring says what each is")
    p.add_argument("--blocks", default=",".join(map(str, densenet.BLOCK_CONFIG)),
                   help="dense layers in each of the 4 blocks (default: DenseNet-121's); fewer make a quick "
                        "check of the forms, as the test suite's")
    p.add_argument("--out", default=None)
    args = p.parse_args(argv)
    try:
        blocks = tuple(int(b) for b in args.blocks.split(","))
    except ValueError:
        blocks = ()
    if len(blocks) != 4 or min(blocks) < 1:
        p.error(f"--blocks takes 4 positive integers, comma-separated (DenseNet-121: 6,12,24,16), got {args.blocks!r}")
    if args.px % 32:
        raise SystemExit(f"--px must be a multiple of 32 (DenseNet-121's stride), got {args.px}")
    dtype = jnp.dtype(args.dtype)
    net = densenet.DenseNet121(dtype=dtype, block_config=blocks)
    # He-normal kernels (init_variables: no compile of flax's init), and running statistics away
    # from (0, 1), so that the check covers BatchNorm's arithmetic.
    shapes = jax.eval_shape(lambda k: net.init(k, jnp.zeros((1, args.px, args.px, 3)), False), jax.random.PRNGKey(0))
    v = init_variables(jax.random.PRNGKey(0), shapes)
    v = {**v, "batch_stats": jax.jit(lambda bs: jax.tree.map(
        lambda s: s + 0.1 * jax.random.uniform(jax.random.PRNGKey(1), s.shape), bs))(v["batch_stats"])}
    on_gpu = jax.devices()[0].platform == "gpu"
    peak = matmul_peak(8192 if on_gpu else 512)
    arch = "DenseNet-121" if blocks == densenet.BLOCK_CONFIG else f"DenseNet, blocks {args.blocks}"
    print(f"device: {jax.devices()[0].device_kind}; {arch} eval, {args.dtype}, inputs {args.px} x {args.px}; "
          f"bf16 matmul peak {peak / 1e12:.1f} TFLOP/s", flush=True)
    all_forms = {"module": lambda v, x: net.apply(v, x, False),
                 "folded": lambda v, x: folded_forward(v, x, dtype, blocks=blocks),
                 "folded_buffer": lambda v, x: folded_forward(v, x, dtype, buffer=True, blocks=blocks),
                 "folded_s2d": lambda v, x: folded_forward(v, x, dtype, s2d=True, blocks=blocks),
                 "folded_s2d_dot": lambda v, x: folded_forward(v, x, dtype, s2d=True, dot=True, blocks=blocks),
                 "folded_s2d_poolfirst": lambda v, x: folded_forward(v, x, dtype, s2d=True, pool_first=True, blocks=blocks),
                 "folded_s2d_pooldot": lambda v, x: folded_forward(v, x, dtype, s2d=True, dot=True, pool_first=True, blocks=blocks),
                 **{f"upto_{c}": lambda v, x, c=c: folded_forward(v, x, dtype, s2d=True, upto=c, blocks=blocks) for c in CUTS},
                 "stem": lambda v, x: stem(v, x, dtype),
                 "stem_s2d": lambda v, x: stem(v, x, dtype, s2d=True)}
    forms = {k: all_forms[k] for k in args.forms.split(",") if k}
    # The module's results the forms are checked against, up to the deepest cut an upto_* form
    # asks for, and its whole output (block4) when the module is not itself a form: one call.
    need = [CUTS.index(_cut_of(k)) for k in forms if k.startswith("upto_")] + [len(CUTS) - 1] * ("module" not in forms)
    rows = []
    for n in [int(b) for b in args.batches.split(",") if b]:
        x = jax.random.normal(jax.random.PRNGKey(n), (n, args.px, args.px, 3))
        cut_refs = {} if not need else {c: np.asarray(y, np.float32) for c, y in jax.jit(
            lambda v, x: module_cuts(net, v, x, CUTS[max(need)]))(v, x).items()}
        ref = None if "module" in forms else cut_refs["block4"]
        module_flops = {}  # cut -> the module's FLOPs up to it
        stems = {}
        for name, fn in forms.items():
            t0 = time.perf_counter()
            jf = jax.jit(fn)
            jf.lower(v, x).compile()
            compile_s = time.perf_counter() - t0
            dt, out = timed(jf, v, x, repeats=args.reps)
            out = np.asarray(out, np.float32)
            ref = out if ref is None else ref
            if name.startswith("stem"):  # checked against the plain stem
                base = stems.setdefault("ref", out)
            elif name.startswith("upto_"):  # against the module's result at the same cut
                base = cut_refs[_cut_of(name)]
            else:
                base = ref
            err = float(np.abs(out - base).max() / max(np.abs(base).max(), 1e-9))
            flops = forward_flops(fn, v, x)
            cut = _cut_of(name)
            if cut not in module_flops:
                module_flops[cut] = forward_flops(lambda v, x: module_cuts(net, v, x, cut)[cut], v, x)
            row = {"form": name, "images": n, "s": dt, "ms_per_1024_images": 1e3 * dt * 1024 / n, "flops": flops,
                   "flops_per_s": flops / dt, "mfu": flops / dt / peak, "module_flops": module_flops[cut],
                   "mfu_of_module_flops": module_flops[cut] / dt / peak, "compile_s": compile_s,
                   "max_rel_diff_to_module": err}
            rows.append(row)
            model = "" if flops == module_flops[cut] else (
                f" (the module's {module_flops[cut] / 1e9:.3g} GFLOP: {100 * row['mfu_of_module_flops']:4.1f} % MFU)")
            print(f"  {name:20s} {n:5d} images: {dt * 1e3:8.2f} ms, {row['ms_per_1024_images']:7.2f} ms per 1024, "
                  f"{flops / dt / 1e12:6.1f} TFLOP/s = {100 * row['mfu']:4.1f} % MFU{model}; compiled in {compile_s:.1f} s; "
                  f"max |diff| / max |out| to module {err:.1e}", flush=True)
    if args.out:
        os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
        with open(args.out, "w") as f:
            json.dump({"device": jax.devices()[0].device_kind, "dtype": args.dtype, "px": args.px, "blocks": list(blocks),
                       "matmul_peak_flops_per_s": peak, "rows": rows, "date": time.strftime("%Y-%m-%d")}, f, indent=2)
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
