"""bench/flop_count.py: convolutions and matmuls counted from the jaxpr, checked against the small
trunk's layer arithmetic and against XLA's own count on CPU (which counts convolutions there)."""
import os
import sys

import jax
import jax.numpy as jnp
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "bench"))
from flop_count import forward_flops, jaxpr_flops  # noqa: E402

from vags_jax.nets import SmallTrunk  # noqa: E402


def _small_trunk_flops(n, p, w):
    """2 x multiply-adds of SmallTrunk(w) on n images of p x p (three 4x4/2 convs, one 3x3/1)."""
    macs = ((p // 2) ** 2 * 16 * 3 * w + (p // 4) ** 2 * 16 * w * 2 * w + (p // 8) ** 2 * 16 * 2 * w * 4 * w
            + (p // 8) ** 2 * 9 * 4 * w * 4 * w)
    return 2 * n * macs


@pytest.fixture(scope="module")
def trunk():
    net = SmallTrunk(width=4)
    x = jnp.zeros((1, 128, 128, 3), jnp.float32)
    return net, net.init(jax.random.PRNGKey(0), x), x


def test_the_small_trunk_counts_its_layers(trunk):
    net, v, x = trunk
    assert forward_flops(lambda x: net.apply(v, x), x) == _small_trunk_flops(1, 128, 4)


def test_it_agrees_with_xla_on_cpu(trunk):
    net, v, x = trunk
    fn = lambda x: net.apply(v, x) @ jnp.ones((16, 5))  # noqa: E731  (a dot_general too)
    cost = jax.jit(fn).lower(x).compile().cost_analysis()
    cost = cost[0] if isinstance(cost, (list, tuple)) else cost
    ours = forward_flops(fn, x)
    assert ours == _small_trunk_flops(1, 128, 4) + 2 * 16 * 16 * 16 * 5
    # XLA leaves out the taps that fall on padding (3 % of them at 128 px, 0.6 % at 320 px)
    assert 0.95 < cost["flops"] / ours < 1.0


def test_space_to_depth_convs_count_the_model_flops_not_the_padded_taps():
    """DenseNet-121's stem runs its 7x7 / 2 conv by space-to-depth over a kernel padded to 8 x 8;
    the count is the 7 x 7 conv's, not the padded kernel's."""
    from vags_jax.nets.densenet import StemConv

    x = jnp.ones((2, 16, 16, 3), jnp.float32)
    stem = StemConv(8)
    v = stem.init(jax.random.PRNGKey(0), x)
    fn = lambda x: stem.apply(v, x)  # noqa: E731
    assert jaxpr_flops(jax.make_jaxpr(fn)(x).jaxpr) == 2 * 2 * 8 * 8 * 8 * 8 * 3 * 8  # as it runs
    jax.jit(fn)(x)  # traced as it runs first, as the bench scripts time before they count
    assert forward_flops(fn, x) == 2 * 2 * 8 * 8 * 7 * 7 * 3 * 8


def test_scan_multiplies_and_cond_takes_the_larger_branch():
    a = jnp.ones((8, 8))
    scanned = lambda a: jax.lax.scan(lambda c, _: (c @ a, None), a, None, length=3)[0]  # noqa: E731
    assert forward_flops(scanned, a) == 3 * 2 * 8 ** 3
    branch = lambda a: jax.lax.cond(a[0, 0] > 0, lambda a: a @ a @ a, lambda a: a @ a, a)  # noqa: E731
    assert forward_flops(branch, a) == 2 * 2 * 8 ** 3
    with pytest.raises(ValueError, match="while_loop"):
        jaxpr_flops(jax.make_jaxpr(lambda a: jax.lax.while_loop(lambda c: c[0, 0] < 9, lambda c: c @ a, a))(a).jaxpr)
