"""Tests for vags_jax.nets: rotations, trunks, GDNet / VANet, pretrained loading.

Kept fast for a 2-core CPU: tiny heightmaps, the small trunk almost everywhere, and DenseNet-121
compiled once at 64 x 32 (batch 1) in a module-scoped fixture; the loader tests only trace it.
"""
from __future__ import annotations

import math
import os
import sys

os.environ.setdefault("JAX_PLATFORMS", "cpu")

import flax.linen as nn
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from vags_jax.config import Net
from vags_jax.nets import (
    DenseNet121,
    count_params,
    densenet121_key_map,
    init_qnet,
    init_variables,
    load_densenet121,
    make_qnet,
    pad_inputs,
    padded_size,
    rotate,
    rotated_inputs,
    rotation_angles,
    to_torchvision_state_dict,
    unrotate,
)
from vags_jax.nets import small as small_mod

HM = 32  # heightmap side for the tests
B = 2


# ----------------------------------------------------------------------------- rotation


def test_rotate_hand_computed():
    img = np.zeros((1, 11, 11, 1), np.float32)
    img[0, 5, 8, 0] = 1.0  # 3 px right of the centre (5, 5): +x
    # +90 deg turns +x into +y: 3 rows below the centre.
    out = np.asarray(rotate(jnp.asarray(img), jnp.array([math.pi / 2])))[0, ..., 0]
    expect = np.zeros((11, 11), np.float32)
    expect[8, 5] = 1.0
    np.testing.assert_allclose(out, expect, atol=1e-5)
    out = np.asarray(rotate(jnp.asarray(img), jnp.array([math.pi])))[0, ..., 0]
    expect = np.zeros((11, 11), np.float32)
    expect[5, 2] = 1.0
    np.testing.assert_allclose(out, expect, atol=1e-5)
    # +90 deg is a clockwise (as displayed) quarter turn: np.rot90(k=-1).
    rng = np.random.default_rng(0)
    x = rng.normal(size=(2, 12, 12, 3)).astype(np.float32)
    out = np.asarray(rotate(jnp.asarray(x), jnp.full((2,), math.pi / 2)))
    np.testing.assert_allclose(out, np.rot90(x, k=-1, axes=(1, 2)), atol=1e-5)


def _blob(h, w, cx, cy, sigma):
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    return np.exp(-((xx - cx) ** 2 + (yy - cy) ** 2) / (2 * sigma**2))


def _centroid(a):
    yy, xx = np.mgrid[0:a.shape[0], 0:a.shape[1]]
    return (a * xx).sum() / a.sum(), (a * yy).sum() / a.sum()


def test_rotate_small_angle_moves_blob_along_the_circle():
    c = 16.0
    img = _blob(33, 33, c + 6, c, 1.5)[None, ..., None]
    a = 3 * math.pi / 8  # 67.5 deg
    out = np.asarray(rotate(jnp.asarray(img), jnp.array([a])))[0, ..., 0]
    cx, cy = _centroid(out)
    assert abs(cx - (c + 6 * math.cos(a))) < 0.05 and abs(cy - (c + 6 * math.sin(a))) < 0.05


def test_rotate_unrotate_round_trip_on_central_disc():
    h = w = 40
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    smooth = np.stack([np.sin(xx / 4.0) * np.cos(yy / 5.0), np.cos((xx + 2 * yy) / 6.0)], -1)
    imgs = jnp.asarray(np.stack([smooth] * 4))
    angles = jnp.array([math.pi / 8, 0.3, -2.0, 5 * math.pi / 8])
    back = np.asarray(unrotate(rotate(imgs, angles), angles))
    disc = (xx - (w - 1) / 2) ** 2 + (yy - (h - 1) / 2) ** 2 <= (h / 2 - 2) ** 2
    err = np.abs(back - smooth[None])[:, disc]
    # two bilinear resamplings blur a wave of |k| ~ 0.37 rad/px by about 2 * k^2 / 8 ~ 0.035
    assert err.max() < 0.05, err.max()
    # and the content is really rotated in between (not an identity)
    mid = np.asarray(rotate(imgs, angles))
    assert np.abs(mid - smooth[None])[:, disc].max() > 0.5


# ----------------------------------------------------------------------------- rotation direction


def _bar(h, w, theta, half_len=10.0, sigma=1.0):
    """A bar through the centre along (cos theta, sin theta) in (col, row)."""
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    x, y = xx - (w - 1) / 2, yy - (h - 1) / 2
    along = x * math.cos(theta) + y * math.sin(theta)
    perp = -x * math.sin(theta) + y * math.cos(theta)
    return (np.exp(-perp**2 / (2 * sigma**2)) * (np.abs(along) <= half_len)).astype(np.float32)


def _net_view(height_map, n_rot=16, stride=8):
    """Height channel of what GDNet's trunks see for every rotation index: (n_rot, P, P)."""
    p = padded_size(height_map.shape[0], stride)
    colour = jnp.zeros(height_map.shape + (3,), jnp.uint8)[None]
    padded = pad_inputs(colour, jnp.asarray(height_map)[None], p)
    theta = rotation_angles(jnp.arange(n_rot)[None], n_rot)
    return np.asarray(rotated_inputs(padded, theta))[..., 3]


def test_the_small_trunks_rewrites_keep_its_arithmetic():
    # StridedConv, both ways, is the 4x4 / 2 conv with padding 1 (same parameter, same result).
    from vags_jax.nets.densenet import conv
    from vags_jax.nets.small import StridedConv
    x = jax.random.normal(jax.random.PRNGKey(4), (2, 12, 16, 3))
    for s2d in (False, True):
        sc = StridedConv(5, space_to_depth=s2d)
        v = sc.init(jax.random.PRNGKey(5), x)
        assert v["params"]["kernel"].shape == (4, 4, 3, 5)
        got = sc.apply(v, x)
        assert got.shape == (2, 6, 8, 5)
        np.testing.assert_allclose(np.asarray(got), np.asarray(conv(5, 4, "c", jnp.float32, stride=2, pad=1).apply(v, x)),
                                   rtol=1e-5, atol=1e-5)
    with pytest.raises(ValueError, match="even height and width"):
        sc.apply(v, x[:, :11])
    # In eval mode the trunk folds each BatchNorm into its conv; the result is the unfolded one's.
    trunk = small_mod.SmallTrunk(width=4)
    xi = jax.random.normal(jax.random.PRNGKey(6), (2, 16, 16, 3))
    tv = trunk.init(jax.random.PRNGKey(7), xi)
    tv = {"params": tv["params"], "batch_stats": jax.tree.map(
        lambda a: a + jax.random.uniform(jax.random.PRNGKey(8), a.shape, minval=0.1, maxval=0.5), tv["batch_stats"])}

    class Unfolded(small_mod.SmallTrunk):  # the layers spelled out, BatchNorm applied as a module
        @nn.compact
        def __call__(self, x, train=False):
            for i, mult in enumerate((1, 2, 4)):
                x = conv(mult * self.width, 4, f"conv{i}", jnp.float32, stride=2, pad=1)(x)
                x = nn.relu(nn.BatchNorm(use_running_average=True, epsilon=1e-5, name=f"norm{i}")(x))
            return conv(4 * self.width, 3, "conv3", jnp.float32, pad=1)(x)

    want = Unfolded(width=4).apply(tv, xi)
    np.testing.assert_allclose(np.asarray(trunk.apply(tv, xi)), np.asarray(want), rtol=1e-5, atol=1e-5)
    assert float(jnp.abs(want).max()) > 0.1


def test_rotation_index_puts_closing_axis_horizontal():
    # Hand-computed: index 4 is theta = 90 deg, closing axis along +y (rows).  The network's
    # input is the map turned by -90 deg, so a marker 5 rows below the centre (+y, on the
    # closing axis) appears 5 columns right of the centre (+x, the horizontal axis).
    hm = np.zeros((HM, HM), np.float32)
    c = HM // 2  # pixel grid centre is 15.5; use a 2x2 marker around (c - 0.5 + 5, c - 0.5)
    hm[c - 1 + 5:c + 1 + 5, c - 1:c + 1] = 1.0
    view = _net_view(hm)[4]
    pc = (view.shape[0] - 1) / 2
    cx, cy = _centroid(view)
    assert abs(cx - (pc + 5)) < 1e-3 and abs(cy - pc) < 1e-3
    # For every index r, a bar along the closing axis theta_r is horizontal in the net's view,
    # and one along theta_r + 90 deg is vertical.
    for r in range(16):
        theta = r * math.pi / 8
        for extra, want_horizontal in ((0.0, True), (math.pi / 2, False)):
            view = _net_view(_bar(HM, HM, theta + extra))[r]
            rows_spread = view.sum(1)  # mass per row
            cols_spread = view.sum(0)
            idx = np.arange(view.shape[0])
            var_row = (rows_spread * (idx - _centroid(view)[1]) ** 2).sum() / view.sum()
            var_col = (cols_spread * (idx - _centroid(view)[0]) ** 2).sum() / view.sum()
            if want_horizontal:
                assert var_col > 20 * var_row, (r, var_col, var_row)
            else:
                assert var_row > 20 * var_col, (r, var_col, var_row)


# ----------------------------------------------------------------------------- Q-networks (small)


@pytest.fixture(scope="module")
def small_gdnet():
    model = make_qnet(Net(trunk="small", small_width=8, head_channels=16), "gdnet")
    variables = init_qnet(jax.random.PRNGKey(0), model, HM, HM)
    rng = np.random.default_rng(1)
    colour = jnp.asarray(rng.integers(0, 256, (B, HM, HM, 3)), jnp.uint8)
    height = jnp.asarray(rng.uniform(0, 0.06, (B, HM, HM)), jnp.float32)
    apply = jax.jit(model.apply, static_argnames=("train",))
    q = apply(variables, colour, height)
    return model, variables, colour, height, apply, q


def test_gdnet_shape_dtype(small_gdnet):
    model, variables, _, _, _, q = small_gdnet
    assert q.shape == (B, 16, HM, HM) and q.dtype == jnp.float32
    assert np.isfinite(np.asarray(q)).all() and float(q.std()) > 0
    w = 8
    assert count_params(variables["params"]["colour_trunk"]) == small_mod.param_count(w)
    assert set(variables) == {"params", "batch_stats"}
    # init_qnet fills exactly the variables model.init declares, with He-normal kernels
    shapes = jax.eval_shape(lambda k: model.init(k, jnp.zeros((1, HM, HM, 3), jnp.uint8),
                                                 jnp.zeros((1, HM, HM))), jax.random.PRNGKey(0))
    assert jax.tree_util.tree_structure(shapes) == jax.tree_util.tree_structure(variables)
    assert all(a.shape == b.shape and a.dtype == b.dtype for a, b in
               zip(jax.tree_util.tree_leaves(shapes), jax.tree_util.tree_leaves(variables)))
    k = np.asarray(variables["params"]["depth_trunk"]["conv3"]["kernel"])  # (3, 3, 32, 32)
    assert abs(k.std() - math.sqrt(2 / (9 * 32))) < 0.1 * math.sqrt(2 / (9 * 32)) and abs(k.mean()) < 0.01
    np.testing.assert_array_equal(variables["batch_stats"]["head"]["norm0"]["var"], 1)
    np.testing.assert_array_equal(variables["params"]["colour_trunk"]["norm1"]["bias"], 0)


def test_gdnet_rotation_subset_matches_full(small_gdnet):
    model, variables, colour, height, apply, q = small_gdnet
    idx = jnp.array([[3, 11], [0, 15]])
    sub = apply(variables, colour, height, rotations=idx)
    assert sub.shape == (B, 2, HM, HM)
    full = np.asarray(q)
    expect = np.stack([full[b, np.asarray(idx[b])] for b in range(B)])
    np.testing.assert_allclose(np.asarray(sub), expect, rtol=1e-4, atol=1e-4)


def test_half_turn_gdnet_is_the_full_turns_distinct_half(small_gdnet):
    # 8 rotations over half a turn are rotations 0..7 of 16 over a whole one (the same angles
    # r * pi / 8), computed with the same variables at half the passes; without half_turn, 8
    # rotations would be r * pi / 4 and differ from index 1 on.
    model, variables, colour, height, apply, q = small_gdnet
    half = make_qnet(Net(trunk="small", small_width=8, head_channels=16, n_rotations=8, half_turn=True), "gdnet")
    got = np.asarray(jax.jit(half.apply, static_argnames=("train",))(variables, colour, height))
    assert got.shape == (B, 8, HM, HM)
    np.testing.assert_allclose(got, np.asarray(q)[:, :8], rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(np.asarray(rotation_angles(jnp.arange(8), 8, half_turn=True)),
                               np.arange(8) * math.pi / 8, rtol=1e-6)
    whole = make_qnet(Net(trunk="small", small_width=8, head_channels=16, n_rotations=8), "gdnet")
    q8 = np.asarray(whole.apply(variables, colour, height, rotations=jnp.array([1])))
    assert np.abs(q8[:, 0] - np.asarray(q)[:, 1]).max() > 1e-3


def test_gdnet_quarter_turn_equivariance(small_gdnet):
    # Turning the scene by +90 deg (a lossless pixel permutation) must give, at rotation
    # index r + 4, exactly the index-r Q map turned by +90 deg: the trunks see identical inputs,
    # so this checks that the output is rotated back with the inverse of the input rotation.
    model, variables, colour, height, apply, q = small_gdnet
    turn = lambda a, axes: np.rot90(np.asarray(a), k=-1, axes=axes)  # = rotate(+pi/2)
    q_turned = apply(variables, jnp.asarray(turn(colour, (1, 2))), jnp.asarray(turn(height, (1, 2))))
    expect = turn(q, (2, 3))
    got = np.roll(np.asarray(q_turned), -4, axis=1)  # got[:, r] = q_turned[:, r + 4]
    scale = float(np.abs(np.asarray(q)).max())
    np.testing.assert_allclose(got, expect, atol=1e-4 * scale)


def test_vanet_shape_and_train_mode():
    model = make_qnet(Net(trunk="small", small_width=8, head_channels=16), "vanet")
    variables = init_qnet(jax.random.PRNGKey(2), model, HM, HM)
    rng = np.random.default_rng(3)
    colour = jnp.asarray(rng.integers(0, 256, (B, HM, HM, 3)), jnp.uint8)
    height = jnp.asarray(rng.uniform(0, 0.06, (B, HM, HM)), jnp.float32)
    q, updates = jax.jit(lambda v, c, h: model.apply(v, c, h, train=True, mutable=["batch_stats"]))(
        variables, colour, height)
    assert q.shape == (B, HM, HM) and q.dtype == jnp.float32 and np.isfinite(np.asarray(q)).all()
    old = variables["batch_stats"]["colour_trunk"]["norm0"]["mean"]
    new = updates["batch_stats"]["colour_trunk"]["norm0"]["mean"]
    assert not np.allclose(old, new)  # running statistics moved


def test_bfloat16_forward_close_to_float32(small_gdnet):
    model, variables, colour, height, apply, q = small_gdnet
    model16 = make_qnet(Net(trunk="small", small_width=8, head_channels=16, dtype="bfloat16"), "gdnet")
    v16 = init_qnet(jax.random.PRNGKey(0), model16, HM, HM)
    assert all(x.dtype == jnp.float32 for x in jax.tree_util.tree_leaves(v16))  # float32 params
    idx = jnp.array([0, 5])
    q16 = jax.jit(model16.apply)(variables, colour, height, rotations=idx)
    assert q16.dtype == jnp.float32
    ref = np.asarray(q)[:, np.asarray(idx)]
    err = np.abs(np.asarray(q16) - ref).max()
    assert 0 < err < 0.02 * np.abs(ref).max(), (err, np.abs(ref).max())  # measured ~0.004


# ----------------------------------------------------------------------------- DenseNet-121


def _torchvision_features_param_count(blocks=(6, 12, 24, 16), growth=32, bn_size=4, init=64):
    """Count torchvision densenet121().features parameters from its layer shapes (weights and
    BN affine; no running statistics)."""
    n = 3 * init * 7 * 7 + 2 * init  # conv0, norm0
    ch = init
    for b, layers in enumerate(blocks):
        for _ in range(layers):
            n += 2 * ch + ch * bn_size * growth  # norm1, conv1 (1x1)
            n += 2 * bn_size * growth + bn_size * growth * growth * 9  # norm2, conv2 (3x3)
            ch += growth
        if b != len(blocks) - 1:
            n += 2 * ch + ch * (ch // 2)  # transition norm, conv (1x1)
            ch //= 2
    return n + 2 * ch, ch  # norm5


@pytest.fixture(scope="module")
def densenet_out():
    x = jax.random.normal(jax.random.PRNGKey(0), (1, 64, 32, 3))
    shapes = jax.eval_shape(lambda k: DenseNet121().init(k, x), jax.random.PRNGKey(0))
    variables = init_variables(jax.random.PRNGKey(1), shapes)
    apply = jax.jit(DenseNet121().apply)
    out = apply(variables, x)
    return out, variables, x, apply


def test_densenet121_param_count_and_stride(densenet_out):
    out, variables, _, _ = densenet_out
    expect, channels = _torchvision_features_param_count()
    assert expect == 6_953_856 and channels == 1024
    assert count_params(variables["params"]) == expect
    assert out.shape == (1, 2, 1, 1024)  # 64 x 32 input, stride 32
    assert np.isfinite(np.asarray(out)).all()
    # running mean + var for every BN channel
    assert count_params(variables["batch_stats"]) == 2 * sum(
        x.size for p, x in jax.tree_util.tree_leaves_with_path(variables["params"]) if "scale" in str(p[-1]))


def test_densenet121_eval_mode_folds_the_batchnorms_after_convolutions(monkeypatch):
    """In eval mode ``norm0`` and each dense layer's ``norm2`` are folded into the conv before
    them (``densenet.conv_bn_relu``); the result is the modules' unfolded arithmetic.  The stem's
    space-to-depth form (``StemConv``) is the 7x7 / 2 conv with padding 3, even and odd sizes.
    On DenseNet-121's layers with 1, 2, 2, 1 of them per block (every layer folds alike; the
    whole DenseNet-121 compiled twice here took about 14 s of the suite)."""
    from vags_jax.nets import densenet

    xs = jax.random.normal(jax.random.PRNGKey(10), (2, 12, 10, 3))
    stem = densenet.StemConv(5)
    sv = stem.init(jax.random.PRNGKey(11), xs)
    assert sv["params"]["kernel"].shape == (7, 7, 3, 5)
    for xi in (xs, xs[:, :11, :9]):
        want = densenet.conv(5, 7, "c", jnp.float32, stride=2, pad=3).apply(sv, xi)
        got = stem.apply(sv, xi)
        assert got.shape == want.shape
        np.testing.assert_allclose(np.asarray(got), np.asarray(want), rtol=1e-5, atol=1e-5)

    blocks = (1, 2, 2, 1)
    x = jax.random.normal(jax.random.PRNGKey(0), (1, 64, 32, 3))
    shapes = jax.eval_shape(lambda k: DenseNet121(block_config=blocks).init(k, x), jax.random.PRNGKey(0))
    variables = init_variables(jax.random.PRNGKey(1), shapes)

    def nudge(tree, shift):  # every 1-D leaf (BatchNorm scales, biases, statistics) moved by shift(name, u)
        leaves, treedef = jax.tree_util.tree_flatten_with_path(tree)
        keys = jax.random.split(jax.random.PRNGKey(9), len(leaves))
        return jax.tree_util.tree_unflatten(treedef, [
            a + shift(p[-1].key, jax.random.uniform(k, a.shape)) if a.ndim == 1 else a
            for (p, a), k in zip(leaves, keys)])

    v = {"params": nudge(variables["params"], lambda name, u: 0.6 * u - 0.3),
         "batch_stats": nudge(variables["batch_stats"], lambda name, u: 0.1 + 0.4 * u if name == "var" else u - 0.5)}
    folded = np.asarray(jax.jit(DenseNet121(block_config=blocks).apply)(v, x))
    monkeypatch.setattr(densenet, "conv_bn_relu", lambda x, c, bn, train, initializing: nn.relu(bn(c(x))))
    monkeypatch.setattr(densenet, "StemConv", lambda features, dtype, name: densenet.conv(
        features, 7, name, dtype, stride=2, pad=3))
    unfolded = np.asarray(jax.jit(DenseNet121(block_config=blocks).apply)(v, x))
    assert np.abs(unfolded).max() > 0.1
    np.testing.assert_allclose(folded, unfolded, rtol=1e-4, atol=1e-5 * np.abs(unfolded).max())


def test_densenet_transition_pools_before_its_conv_and_computes_conv_then_pool():
    """``Transition`` runs BN-ReLU-avgpool-1x1 conv; its result in both modes (and its running
    statistics in train mode) are torchvision's order, BN-ReLU-1x1 conv-avgpool, also on odd
    sizes, where both orders drop the last row and column."""
    from vags_jax.nets import densenet

    t = densenet.Transition(3)
    x = jax.random.normal(jax.random.PRNGKey(12), (2, 6, 7, 5))
    v = t.init(jax.random.PRNGKey(13), x, False)
    v = {"params": v["params"], "batch_stats": jax.tree.map(lambda a: a + 0.3, v["batch_stats"])}
    v["params"]["norm"] = {"scale": jnp.linspace(0.5, 1.5, 5), "bias": jnp.linspace(-0.4, 0.4, 5)}

    def conv_then_pool(variables, x, train):
        bn = densenet.batch_norm("norm", train, jnp.float32)
        y, upd = bn.apply({"params": variables["params"]["norm"], "batch_stats": variables["batch_stats"]["norm"]},
                          x, mutable=["batch_stats"])
        y = densenet.conv(3, 1, "conv", jnp.float32).apply({"params": variables["params"]["conv"]}, nn.relu(y))
        return nn.avg_pool(y, (2, 2), strides=(2, 2), padding="VALID"), upd["batch_stats"]

    for train in (False, True):
        got, upd = t.apply(v, x, train, mutable=["batch_stats"])
        want, want_stats = conv_then_pool(v, x, train)
        assert got.shape == (2, 3, 3, 3)
        np.testing.assert_allclose(np.asarray(got), np.asarray(want), rtol=1e-5, atol=1e-6)
        for a, b in zip(jax.tree.leaves(upd["batch_stats"]["norm"]), jax.tree.leaves(want_stats)):
            np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-6)


# ----------------------------------------------------------------------------- pretrained loading


@pytest.fixture(scope="module")
def densenet_gdnet_vars():
    """Zero variables of a DenseNet GDNet (shapes by tracing only; no compilation)."""
    model = make_qnet(Net(), "gdnet")
    shapes = jax.eval_shape(lambda k: model.init(k, jnp.zeros((1, HM, HM, 3), jnp.uint8),
                                                 jnp.zeros((1, HM, HM)), rotations=jnp.zeros((1,), jnp.int32)),
                            jax.random.PRNGKey(0))
    return jax.tree_util.tree_map(lambda s: np.zeros(s.shape, s.dtype), shapes)


def _synthetic_state_dict(variables, seed=0):
    rng = np.random.default_rng(seed)
    sd = {}
    for key, (coll, path, kind) in densenet121_key_map().items():
        leaf = variables[coll]["colour_trunk"]
        for p in path:
            leaf = leaf[p]
        shape = leaf.shape
        if kind == "conv":
            shape = (shape[3], shape[2], shape[0], shape[1])  # HWIO -> torch OIHW
        sd[key] = rng.normal(size=shape).astype(np.float32)
    sd["features.norm0.num_batches_tracked"] = np.array(7, np.int64)
    sd["classifier.weight"] = rng.normal(size=(1000, 1024)).astype(np.float32)
    sd["classifier.bias"] = np.zeros(1000, np.float32)
    return sd


def test_load_synthetic_npz_puts_tensors_in_place(densenet_gdnet_vars, tmp_path):
    variables = densenet_gdnet_vars
    sd = _synthetic_state_dict(variables)
    path = tmp_path / "densenet121.npz"
    np.savez(path, **sd)
    loaded = load_densenet121(variables, path)
    for trunk in ("colour_trunk", "depth_trunk"):
        p, s = loaded["params"][trunk], loaded["batch_stats"][trunk]
        w = sd["features.conv0.weight"]  # (64, 3, 7, 7) OIHW
        assert p["conv0"]["kernel"].shape == (7, 7, 3, 64)
        assert float(p["conv0"]["kernel"][2, 3, 1, 5]) == w[5, 1, 2, 3]
        w = sd["features.denseblock2.denselayer7.conv2.weight"]  # (32, 128, 3, 3)
        assert float(p["denseblock2"]["denselayer7"]["conv2"]["kernel"][0, 2, 127, 31]) == w[31, 127, 0, 2]
        w = sd["features.transition3.conv.weight"]  # (512, 1024, 1, 1)
        assert float(p["transition3"]["conv"]["kernel"][0, 0, 1000, 7]) == w[7, 1000, 0, 0]
        np.testing.assert_array_equal(s["denseblock3"]["denselayer7"]["norm2"]["mean"],
                                      sd["features.denseblock3.denselayer7.norm2.running_mean"])
        np.testing.assert_array_equal(s["norm5"]["var"], sd["features.norm5.running_var"])
        np.testing.assert_array_equal(p["norm5"]["scale"], sd["features.norm5.weight"])
        np.testing.assert_array_equal(p["norm0"]["bias"], sd["features.norm0.bias"])
        back = to_torchvision_state_dict(loaded, trunk)
        assert set(back) == set(densenet121_key_map())
        for k, v in back.items():
            np.testing.assert_array_equal(v, sd[k], err_msg=k)
    # the head is untouched, the input is not modified
    np.testing.assert_array_equal(loaded["params"]["head"]["conv0"]["kernel"], 0)
    assert not np.asarray(variables["params"]["colour_trunk"]["conv0"]["kernel"]).any()
    # old torchvision spelling ("norm.1") and a "module." prefix are accepted
    old = {("module." + k).replace("denselayer1.norm1.", "denselayer1.norm.1."): v for k, v in sd.items()}
    again = load_densenet121(variables, old)
    np.testing.assert_array_equal(again["params"]["depth_trunk"]["denseblock4"]["denselayer1"]["norm1"]["scale"],
                                  sd["features.denseblock4.denselayer1.norm1.weight"])


def test_load_errors_are_clear(densenet_gdnet_vars, monkeypatch, tmp_path):
    variables = densenet_gdnet_vars
    sd = _synthetic_state_dict(variables, seed=1)
    missing = dict(sd)
    del missing["features.denseblock1.denselayer3.conv2.weight"]
    with pytest.raises(ValueError, match=r"missing 1 of .*denseblock1\.denselayer3\.conv2\.weight"):
        load_densenet121(variables, missing)
    bad = dict(sd)
    bad["features.norm5.weight"] = np.zeros(1000, np.float32)
    with pytest.raises(ValueError, match=r"features\.norm5\.weight: got \(1000,\), expected \(1024,\)"):
        load_densenet121(variables, bad)
    extra = dict(sd, **{"features.denseblock9.weight": np.zeros(3)})
    with pytest.raises(ValueError, match="denseblock9"):
        load_densenet121(variables, extra)
    small_model = make_qnet(Net(trunk="small", small_width=8), "gdnet")
    small_vars = jax.eval_shape(lambda k: init_qnet(k, small_model, HM, HM), jax.random.PRNGKey(0))
    with pytest.raises(ValueError, match="densenet121"):
        load_densenet121(small_vars, sd)
    # .pth without torch: a clear ImportError that explains the .npz route
    pth = tmp_path / "w.pth"
    pth.write_bytes(b"not really a checkpoint")
    monkeypatch.setitem(sys.modules, "torch", None)
    with pytest.raises(ImportError, match=r"needs torch.*\.npz"):
        load_densenet121(variables, pth)


def test_load_pth_with_torch(densenet_gdnet_vars, tmp_path):
    torch = pytest.importorskip("torch")
    variables = densenet_gdnet_vars
    sd = _synthetic_state_dict(variables, seed=2)
    path = tmp_path / "densenet121.pth"
    torch.save({k: torch.from_numpy(v) for k, v in sd.items()}, path)
    loaded = load_densenet121(variables, path, trunks=("depth_trunk",))
    w = sd["features.conv0.weight"]
    assert float(loaded["params"]["depth_trunk"]["conv0"]["kernel"][6, 0, 2, 63]) == w[63, 2, 6, 0]
    assert not np.asarray(loaded["params"]["colour_trunk"]["conv0"]["kernel"]).any()  # not asked for


def _torch_densenet121(torch):
    """A hand-written torch DenseNet-121 with torchvision's module names (for parity only)."""
    from collections import OrderedDict

    tnn, F = torch.nn, torch.nn.functional

    class Layer(tnn.Module):
        def __init__(self, c):
            super().__init__()
            self.norm1, self.conv1 = tnn.BatchNorm2d(c), tnn.Conv2d(c, 128, 1, bias=False)
            self.norm2, self.conv2 = tnn.BatchNorm2d(128), tnn.Conv2d(128, 32, 3, padding=1, bias=False)

        def forward(self, x):
            y = self.conv1(F.relu(self.norm1(x)))
            return torch.cat([x, self.conv2(F.relu(self.norm2(y)))], 1)

    mods = OrderedDict(conv0=tnn.Conv2d(3, 64, 7, 2, 3, bias=False), norm0=tnn.BatchNorm2d(64),
                       relu0=tnn.ReLU(), pool0=tnn.MaxPool2d(3, 2, 1))
    ch = 64
    for b, n in enumerate((6, 12, 24, 16), start=1):
        layers = OrderedDict()
        for i in range(n):
            layers[f"denselayer{i + 1}"] = Layer(ch)
            ch += 32
        mods[f"denseblock{b}"] = tnn.Sequential(layers)
        if b != 4:
            mods[f"transition{b}"] = tnn.Sequential(OrderedDict(
                norm=tnn.BatchNorm2d(ch), relu=tnn.ReLU(), conv=tnn.Conv2d(ch, ch // 2, 1, bias=False),
                pool=tnn.AvgPool2d(2, 2)))
            ch //= 2
    mods["norm5"] = tnn.BatchNorm2d(ch)
    model = tnn.Module()
    model.features = tnn.Sequential(mods)
    return model


def test_densenet121_matches_torch_layout(densenet_out):
    """Same weights, same input: our DenseNet-121 equals a torch one (padding, pooling, BN)."""
    torch = pytest.importorskip("torch")
    _, variables, x, apply = densenet_out
    rng = np.random.default_rng(5)
    sd = {}
    for key, (coll, path, kind) in densenet121_key_map().items():
        leaf = variables[coll]
        for p in path:
            leaf = leaf[p]
        if kind == "conv":
            h, w, i, o = leaf.shape
            sd[key] = (rng.normal(size=(o, i, h, w)) * math.sqrt(2 / (h * w * i))).astype(np.float32)
        elif key.endswith("running_var") or key.endswith(".weight"):
            sd[key] = rng.uniform(0.5, 1.5, leaf.shape).astype(np.float32)
        else:
            sd[key] = rng.normal(0, 0.2, leaf.shape).astype(np.float32)
    ours = np.asarray(apply(load_densenet121(variables, sd, trunks=(None,)), x))  # (1, 2, 1, 1024)
    model = _torch_densenet121(torch).eval()
    model.load_state_dict({k: torch.from_numpy(v) for k, v in sd.items()}, strict=False)
    with torch.no_grad():
        ref = model.features(torch.from_numpy(np.array(x).transpose(0, 3, 1, 2))).numpy()
    np.testing.assert_allclose(ours, ref.transpose(0, 2, 3, 1), rtol=2e-3, atol=2e-3 * np.abs(ref).max())


def test_net_init_starts_both_trunks_from_the_state_dict(densenet_gdnet_vars, tmp_path, monkeypatch):
    """``net.init``: a fresh network (``initial_variables``) is ``init_qnet``'s with the state
    dict in both trunks and its head as drawn; ``check_init`` reads and fits the file first,
    by tracing (nothing compiled).  init_qnet is replaced by the zero variables here."""
    from vags_jax.nets import check_init, initial_variables
    from vags_jax.nets import pretrained

    sd = _synthetic_state_dict(densenet_gdnet_vars, seed=2)
    path = tmp_path / "densenet121.npz"
    np.savez(path, **sd)
    monkeypatch.setattr(pretrained, "init_qnet", lambda key, model, h, w: densenet_gdnet_vars)
    model = make_qnet(Net(), "gdnet")
    assert initial_variables(jax.random.PRNGKey(0), model, Net(), HM, HM) is densenet_gdnet_vars  # no init: as drawn
    net_cfg = Net(init=str(path))
    check_init(net_cfg, model, HM, HM)
    loaded = initial_variables(jax.random.PRNGKey(0), model, net_cfg, HM, HM)
    for trunk in ("colour_trunk", "depth_trunk"):
        np.testing.assert_array_equal(loaded["params"][trunk]["conv0"]["kernel"],
                                      sd["features.conv0.weight"].transpose(2, 3, 1, 0))
        np.testing.assert_array_equal(loaded["batch_stats"][trunk]["norm5"]["mean"], sd["features.norm5.running_mean"])
    np.testing.assert_array_equal(loaded["params"]["head"]["conv0"]["kernel"], 0)
    # What train.py says before compiling, for a file that is not there or does not fit.
    with pytest.raises(ValueError, match=r"net\.init '.*none\.npz': no such file; .*nothing is downloaded"):
        check_init(Net(init=str(tmp_path / "none.npz")), model, HM, HM)
    del sd["features.denseblock1.denselayer3.conv2.weight"]
    np.savez(path, **sd)
    with pytest.raises(ValueError, match=r"net\.init '.*densenet121\.npz': DenseNet-121 state dict is missing 1 of"):
        check_init(net_cfg, model, HM, HM)
