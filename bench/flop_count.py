"""Model FLOPs of a JAX function, counted from its jaxpr (no compiling).

Why: XLA's ``cost_analysis`` of a DQN update on an H100 gave 1-3 % of the FLOPs its
convolutions do, so the MFU computed from it was far too low (bench/RESULTS.md, "Where the
update's time goes").  Here every ``conv_general_dilated`` and ``dot_general`` of the traced
program counts ``2 * (output elements) * (multiply-adds per output element)``, whole kernel
windows (XLA's own count on CPU leaves out the taps that fall on padding: 0.6 % fewer for the
small trunk at 320 px); elementwise work, gathers and reductions count nothing (the usual "model
FLOPs").  Calls, ``jit``, ``remat``, custom derivatives and ``scan`` (times its length) are
followed; ``cond`` counts its largest branch.  A ``while_loop`` has no static trip count and
raises.

Space-to-depth convolutions (``vags_jax.nets.densenet.stride2_conv_by_space_to_depth``: the
small trunk's first conv, DenseNet-121's stem) are traced as the strided convolutions they
compute, so the zero taps of a kernel padded to an even size (DenseNet-121's 7 x 7 to 8 x 8: 1.3 %
of a pass) are not counted as model FLOPs.

DenseNet-121's transitions (``densenet.pooled_pointwise_conv``: the 1x1 conv after the 2x2
average pool, on a quarter of the pixels) are traced in torchvision's order, conv then pool, so
that the model FLOPs stay the architecture's own (the three convs' 10.9 % of a pass, not a
quarter of that) and MFU figures stay comparable.

Count a forward pass; a training step's model FLOPs are the usual 3 x forward (forward, and
the two products of the backward pass), which leaves out the zeros a strided convolution's
input gradient multiplies.

    from flop_count import forward_flops       # with bench/ on sys.path
    flops = forward_flops(lambda x: net.apply(variables, x), images)
"""
from __future__ import annotations

import contextlib
import importlib
import math
from typing import Callable

import flax.linen as nn
import jax
from jax.extend import core as jcore


def _conv(eqn) -> float:
    rhs = eqn.invars[1].aval
    out = eqn.outvars[0].aval
    spec = eqn.params["dimension_numbers"].rhs_spec  # (out features, in features, spatial...)
    per_output = rhs.shape[spec[1]] * math.prod(rhs.shape[d] for d in spec[2:])
    return 2.0 * math.prod(out.shape) * per_output


def _dot(eqn) -> float:
    lhs = eqn.invars[0].aval
    (contract_lhs, _), _ = eqn.params["dimension_numbers"]
    return 2.0 * math.prod(eqn.outvars[0].aval.shape) * math.prod(lhs.shape[d] for d in contract_lhs)


def _sub_jaxprs(value):
    if isinstance(value, jcore.ClosedJaxpr):
        yield value.jaxpr
    elif isinstance(value, jcore.Jaxpr):
        yield value
    elif isinstance(value, (tuple, list)):
        for v in value:
            yield from _sub_jaxprs(v)


def jaxpr_flops(jaxpr) -> float:
    """FLOPs of a ``Jaxpr`` (module docstring for what counts)."""
    total = 0.0
    for eqn in jaxpr.eqns:
        name = eqn.primitive.name
        if name == "conv_general_dilated":
            total += _conv(eqn)
        elif name == "dot_general":
            total += _dot(eqn)
        elif name == "while":
            raise ValueError("jaxpr_flops: a while_loop has no static trip count")
        elif name == "cond":
            total += max(jaxpr_flops(b.jaxpr) for b in eqn.params["branches"])
        else:
            inner = sum(jaxpr_flops(j) for v in eqn.params.values() for j in _sub_jaxprs(v))
            total += inner * (eqn.params["length"] if name == "scan" else 1)
    return total


# The modules that call the space-to-depth convolution by this name.
_S2D_USERS = ("vags_jax.nets.densenet", "vags_jax.nets.small")


def _strided_conv(x, kernel, pad: int):
    return jax.lax.conv_general_dilated(x, kernel, (2, 2), ((pad, pad), (pad, pad)),
                                        dimension_numbers=("NHWC", "HWIO", "NHWC"))


def _conv_then_pool(x, c):
    return nn.avg_pool(c(x), (2, 2), strides=(2, 2), padding="VALID")


@contextlib.contextmanager
def model_arithmetic():
    """While tracing: space-to-depth convolutions as the plain strided convolutions they compute,
    DenseNet-121's transitions as conv then pool."""
    mods = [importlib.import_module(m) for m in _S2D_USERS]
    saved = [m.stride2_conv_by_space_to_depth for m in mods]
    dense = importlib.import_module("vags_jax.nets.densenet")
    pooled = dense.pooled_pointwise_conv
    try:
        for m in mods:
            m.stride2_conv_by_space_to_depth = _strided_conv
        dense.pooled_pointwise_conv = _conv_then_pool
        yield
    finally:
        for m, f in zip(mods, saved):
            m.stride2_conv_by_space_to_depth = f
        dense.pooled_pointwise_conv = pooled


def forward_flops(fn: Callable, *args) -> float:
    """Model FLOPs of ``fn(*args)`` (traced with ``jax.make_jaxpr`` under ``model_arithmetic``,
    never compiled)."""
    with model_arithmetic():  # a new function object: JAX's trace cache may hold fn traced without it
        return jaxpr_flops(jax.make_jaxpr(lambda *a: fn(*a))(*args).jaxpr)
