"""Tests for GG-CNN: the network, depth pre/post-processing, world grasps, labels, training.

Fast on a 2-core CPU: the 300 x 300 network is only traced (``jax.eval_shape``); everything that
runs does so on images of 24-48 pixels; the jitted training step is built once per module.
"""
from __future__ import annotations

import math
import os

os.environ.setdefault("JAX_PLATFORMS", "cpu")

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy import ndimage

from vags_jax.perception import camera as cam_lib
from vags_jax.config import Camera
from vags_jax.ggcnn.labels import GraspCandidates, label_maps
from vags_jax.ggcnn.process import (
    best_grasp,
    crop_resize,
    gaussian_blur,
    grasp_to_world,
    inpaint_depth,
    peak,
    preprocess_depth,
    sample_depth,
)
from vags_jax.ggcnn.train import (
    augment_batch,
    augment_sample,
    ggcnn_loss,
    init_train_state,
    make_train_step,
    sample_augmentation,
)
from vags_jax.nets import GGCNN, GGCNNConfig, GraspMaps, count_params, init_ggcnn

SMALL = 24  # network resolution for the tests that run it (a multiple of 12)


@pytest.fixture(scope="module")
def model():
    return GGCNN()


@pytest.fixture(scope="module")
def params(model):
    return init_ggcnn(jax.random.PRNGKey(0), model, size=SMALL)


def cands(center, angle, length, jaw, success):
    return GraspCandidates(
        center=jnp.asarray(center, jnp.float32), angle=jnp.asarray(angle, jnp.float32),
        length=jnp.asarray(length, jnp.float32), jaw=jnp.asarray(jaw, jnp.float32),
        success=jnp.asarray(success, bool),
    )


def pixel_set(mask):
    """{(u, v)} of the True pixels of an (H, W) mask."""
    v, u = np.nonzero(np.asarray(mask))
    return set(zip(u.tolist(), v.tolist()))


# ----------------------------------------------------------------------------- network


def test_parameter_count_and_shapes(model, params):
    assert count_params(params["params"]) == 62_420
    # The real 300 x 300 geometry, traced only: every map comes out 300 x 300.
    out = jax.eval_shape(model.apply, params, jax.ShapeDtypeStruct((2, 300, 300, 1), jnp.float32))
    for name in ("quality", "cos", "sin", "width"):
        assert getattr(out, name).shape == (2, 300, 300)
        assert getattr(out, name).dtype == jnp.float32
    # (B, H, W) is accepted too; and a real forward pass at the small size.
    maps = model.apply(params, jnp.zeros((3, SMALL, SMALL), jnp.float32))
    assert maps.quality.shape == (3, SMALL, SMALL)
    assert GraspMaps.unstack(maps.stack()).width.shape == (3, SMALL, SMALL)


@pytest.mark.parametrize(
    "shape, dtype, match",
    [
        ((300, 300), jnp.float32, "shape"),            # no batch axis
        ((1, 300, 300, 3), jnp.float32, "shape"),      # three channels
        ((1, 301, 300, 1), jnp.float32, "multiples of 12"),
        ((1, 300, 300, 1), jnp.int32, "float"),
    ],
)
def test_network_rejects_bad_input(model, params, shape, dtype, match):
    with pytest.raises(ValueError, match=match):
        jax.eval_shape(model.apply, params, jax.ShapeDtypeStruct(shape, dtype))


def test_config_validation():
    with pytest.raises(ValueError, match="input_size"):
        GGCNNConfig(input_size=301)
    with pytest.raises(ValueError, match="zoom_range"):
        GGCNNConfig(zoom_range=(0.0, 1.0))
    with pytest.raises(ValueError, match="rotation"):
        GGCNNConfig(rotation="half")
    with pytest.raises(ValueError, match="GGCNNConfig.labels must be one of"):
        GGCNNConfig(labels="failures")
    with pytest.raises(ValueError, match="untried_weight"):
        GGCNNConfig(untried_weight=1.5)


# ----------------------------------------------------------------------------- labels


def test_labels_centre_third_rule():
    h, w = 20, 24
    c = cands(
        center=[[10, 8], [4, 4], [20, 14], [5, 15]],
        angle=[0.0, 0.0, math.pi / 2, math.pi / 4],
        length=[18, 18, 12, 12],
        jaw=[4, 4, 3, 2],
        success=[True, False, True, True],
    )
    maps = label_maps(c, h, w, mode="positives")  # GG-CNN's rule (B's failure overlaps A at (7, 6))
    assert maps.quality.shape == (h, w)
    # Hand-computed centre thirds.  A: theta 0, length 18 -> |du| <= 3; jaw 4 -> |dv| <= 2.
    a = {(u, v) for u in range(7, 14) for v in range(6, 11)}
    # B failed: not drawn (in "success_ratio" its overlap with A, (7, 6), would be 1/2).  C: theta 90 deg, length 12 -> |dv| <= 2; jaw 3 -> |du| <= 1.5.
    cc = {(u, v) for u in range(19, 22) for v in range(12, 17)}
    # D: theta 45 deg, length 12 -> |du + dv| / sqrt 2 <= 2; jaw 2 -> |dv - du| / sqrt 2 <= 1.
    d = {(5 + du, 15 + dv) for du, dv in [(-1, -1), (0, 0), (1, 1), (0, -1), (-1, 0), (1, 0), (0, 1)]}
    q = np.asarray(maps.quality)
    assert pixel_set(q == 1.0) == a | cc | d
    assert set(np.unique(q)) == {0.0, 1.0}
    for pix, theta, length in [(a, 0.0, 18), (cc, math.pi / 2, 12), (d, math.pi / 4, 12)]:
        us = np.array([p[0] for p in pix])
        vs = np.array([p[1] for p in pix])
        np.testing.assert_allclose(np.asarray(maps.cos)[vs, us], math.cos(2 * theta), atol=1e-6)
        np.testing.assert_allclose(np.asarray(maps.sin)[vs, us], math.sin(2 * theta), atol=1e-6)
        np.testing.assert_allclose(np.asarray(maps.width)[vs, us], length / 150, rtol=1e-6)
    outside = q == 0
    for m in (maps.cos, maps.sin, maps.width):
        assert np.all(np.asarray(m)[outside] == 0)
    # Candidates are tested in chunks; the chunk size (here 3: one full chunk and one padded)
    # does not change the maps.
    for name, a, b in zip(("q", "c", "s", "w"), maps.stack().T, label_maps(c, h, w, chunk=3, mode="positives").stack().T):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b), err_msg=name)


def test_labels_overlap_batch_and_width_clip():
    # Image 0: two positives overlapping at (10, 8); the later one (index 1) wins there.
    # Image 1: one wide grasp (length 300 px > 150 -> width clipped to 1); its other slot failed.
    c = cands(
        center=[[[10, 8], [12, 8]], [[6, 6], [0, 0]]],
        angle=[[0.0, math.pi / 2], [0.3, 0.0]],
        length=[[18, 12], [300, 18]],
        jaw=[[4, 4], [1, 4]],
        success=[[True, True], [True, False]],
    )
    for chunk in (1, 2):  # the later grasp wins across chunks and within one
        maps = jax.jit(label_maps, static_argnums=(1, 2, 3, 4))(c, 16, 20, 150.0, chunk)
        assert maps.quality.shape == (2, 16, 20)
        assert float(maps.cos[0, 8, 10]) == pytest.approx(-1.0)  # cos(2 * 90 deg): the later grasp
        assert float(maps.cos[0, 8, 8]) == pytest.approx(1.0)    # only the first covers (8, 8)
    assert float(maps.quality[1, 6, 6]) == 1.0 and float(maps.width[1, 6, 6]) == 1.0
    assert float(maps.quality[1, 0, 0]) == 0.0


def test_success_ratio_labels_count_failures():
    # theta 0, length 6 -> |du| <= 1; jaw 3 -> |dv| <= 1.5.  A succeeded at (4, 5): u 3..5,
    # v 4..6.  B failed at (5, 5): u 4..6, v 4..6.  C failed at (9, 9) with jaw 1: u 8..10, v 9.
    c = cands(center=[[4, 5], [5, 5], [9, 9]], angle=[0.0, 0.0, 0.0], length=[6, 6, 6], jaw=[3, 3, 1],
              success=[True, False, False])
    h = w = 12
    a = {(u, v) for u in range(3, 6) for v in range(4, 7)}
    b = {(u, v) for u in range(4, 7) for v in range(4, 7)}
    cc = {(u, v) for u in range(8, 11) for v in [9]}
    maps = label_maps(c, h, w)  # the default: success ratio
    q = np.asarray(maps.quality)
    # 1 where only A covers (u = 3), 1/2 where A and B do (u = 4, 5), 0 where only failures do.
    assert pixel_set(q == 1.0) == {(3, v) for v in range(4, 7)}
    assert pixel_set(q == 0.5) == {(u, v) for u in (4, 5) for v in range(4, 7)}
    assert pixel_set(q > 0) == a
    # The angle and width come from the success only.
    assert pixel_set(np.asarray(maps.width) > 0) == a
    np.testing.assert_allclose(np.asarray(maps.cos)[4:7, 3:6], 1.0)
    # Loss weight: 1 on every tried pixel (successes and failures), untried_weight elsewhere.
    from vags_jax.ggcnn.labels import labels_and_weight

    _, weight = labels_and_weight(c, h, w, untried_weight=0.25)
    wt = np.asarray(weight)
    assert pixel_set(wt == 1.0) == a | b | cc
    assert pixel_set(wt == 0.25) == {(u, v) for u in range(w) for v in range(h)} - (a | b | cc)
    # Chunks of 2 (one padded with a dummy at (0, 0)): the same maps and weights.
    maps2, weight2 = labels_and_weight(c, h, w, chunk=2, untried_weight=0.25)
    np.testing.assert_array_equal(np.asarray(maps2.stack()), np.asarray(maps.stack()))
    np.testing.assert_array_equal(np.asarray(weight2), wt)
    # GG-CNN's rule, kept as "positives": the success only, every pixel weight 1.
    pos, weight = labels_and_weight(c, h, w, mode="positives")
    assert pixel_set(np.asarray(pos.quality) == 1.0) == a and set(np.unique(pos.quality)) == {0.0, 1.0}
    assert np.all(np.asarray(weight) == 1.0)
    with pytest.raises(ValueError, match="label mode must be one of"):
        label_maps(c, h, w, mode="ratio")


def test_labels_reject_bad_shapes():
    good = dict(center=[[1, 1]], angle=[0.0], length=[3.0], jaw=[2.0], success=[True])
    with pytest.raises(ValueError, match="center"):
        label_maps(cands(**{**good, "center": [1, 1]}), 8, 8)
    with pytest.raises(ValueError, match="success"):
        label_maps(cands(**{**good, "success": [True, False]}), 8, 8)


# ----------------------------------------------------------------------------- preprocessing


def test_preprocess_fills_holes_and_clips():
    d = np.full((2, 24, 24), 0.5, np.float32)
    d[0, 4:10, 4:10] = 0.4           # a box
    d[0, 6, 6] = 0.0                 # one missing pixel inside the box
    d[0, 14:20, 14:20] = np.nan      # a wide hole in the table
    d[0, 10, 4:10] = 0.0             # a row missing along the box's lower edge
    d[1] = 0.2
    d[1, :, 12:] = 3.0               # 2.8 m step: clipped
    x, filled, ok = preprocess_depth(jnp.asarray(d))
    filled, x = np.asarray(filled), np.asarray(x)
    assert ok.tolist() == [True, True]
    assert np.all(np.isfinite(filled)) and np.all(filled > 0)
    assert filled[0, 6, 6] == pytest.approx(0.4)                  # all neighbours 0.4
    np.testing.assert_allclose(filled[0, 14:20, 14:20], 0.5)      # the hole grows in from 0.5
    assert 0.4 < filled[0, 10, 6] < 0.5                            # between box and table
    valid = np.isfinite(d) & (d > 0)
    np.testing.assert_array_equal(filled[valid], d[valid])        # valid pixels kept
    mean0 = d[0][valid[0]].mean()
    np.testing.assert_allclose(x[0], np.clip(filled[0] - mean0, -1, 1), atol=1e-6)
    assert x[1].max() == 1.0 and x[1].min() == -1.0  # mean 1.6: 0.2 - 1.6 and 3.0 - 1.6 clipped
    # A capped fill leaves a wide hole's middle at the frame's mean valid depth.
    capped, _ = inpaint_depth(jnp.asarray(d[:1]), iters=1)
    assert float(capped[0, 17, 17]) == pytest.approx(float(mean0), rel=1e-5)
    assert float(capped[0, 14, 14]) == pytest.approx(0.5)         # ring 1 filled normally


def test_preprocess_rejects_bad_depth():
    with pytest.raises(ValueError, match=r"\(B, H, W\)"):
        preprocess_depth(jnp.ones((24, 24), jnp.float32))
    with pytest.raises(ValueError, match="float depth in metres"):
        preprocess_depth(jnp.ones((1, 24, 24), jnp.uint16))
    d = np.ones((3, 12, 12), np.float32)
    d[1] = np.nan
    d[2] = 0.0
    with pytest.raises(ValueError, match=r"frame\(s\) \[1, 2\] have no valid pixel"):
        preprocess_depth(jnp.asarray(d))
    # Inside jit it cannot raise: the frame comes back flagged and zero.
    x, _, ok = jax.jit(preprocess_depth)(jnp.asarray(d))
    assert ok.tolist() == [True, False, False]
    assert np.all(np.asarray(x[1:]) == 0)


def test_crop_resize_intrinsics_and_holes():
    h, w = 40, 60
    fx, cx, cy = 50.0, 30.0, 20.0
    k = np.array([[fx, 0, cx], [0, fx, cy], [0, 0, 1]], np.float32)
    u = np.arange(w, dtype=np.float32)
    d = np.broadcast_to(1.0 + 0.01 * u, (1, h, w)).copy()
    d[0, :, 50:] = 0.0          # missing columns (outside the crop)
    d[0, 20, 30] = 0.0          # one hole inside the crop
    d[0, 30:36, 36:44] = np.nan  # a missing block inside the crop
    cfg = GGCNNConfig(input_size=24, crop_size=36)  # s = 1.5, crop from row 2, column 12
    out, k_out = crop_resize(jnp.asarray(d), jnp.asarray(k), cfg)
    assert out.shape == (1, 24, 24) and k_out.shape == (1, 3, 3)
    s, r0, c0 = 1.5, 2, 12
    np.testing.assert_allclose(
        np.asarray(k_out[0]),
        [[fx / s, 0, (cx - c0 + 0.5) / s - 0.5], [0, fx / s, (cy - r0 + 0.5) / s - 0.5], [0, 0, 1]],
        rtol=1e-6,
    )
    # Output pixel (i, j) reads camera pixel (r0 + (i + 0.5) s - 0.5, c0 + (j + 0.5) s - 0.5), and
    # its ray through K_out is that camera pixel's ray through K.
    j = np.arange(24)
    u_src = c0 + (j + 0.5) * s - 0.5
    v_src = r0 + (j + 0.5) * s - 0.5
    ko = np.asarray(k_out[0])
    np.testing.assert_allclose((j - ko[0, 2]) / ko[0, 0], (u_src - cx) / fx, atol=1e-6)
    np.testing.assert_allclose((j - ko[1, 2]) / ko[1, 1], (v_src - cy) / fx, atol=1e-6)
    # Bilinear over valid taps only: all four valid -> the linear depth exactly; none valid ->
    # missing (0); some valid -> between the valid taps' depths (holes do not pull towards 0).
    valid = np.isfinite(d[0]) & (d[0] > 0)
    o = np.asarray(out[0])
    counts = {"all": 0, "none": 0, "some": 0}
    for i in range(24):
        for jj in range(24):
            r, c = int(np.floor(v_src[i])), int(np.floor(u_src[jj]))
            taps = [(r, c), (r, c + 1), (r + 1, c), (r + 1, c + 1)]
            ok = [valid[t] for t in taps]
            if all(ok):
                counts["all"] += 1
                assert o[i, jj] == pytest.approx(1.0 + 0.01 * u_src[jj], rel=1e-6)
            elif not any(ok):
                counts["none"] += 1
                assert o[i, jj] == 0.0
            else:
                counts["some"] += 1
                vals = [d[0][t] for t, g in zip(taps, ok) if g]
                assert min(vals) - 1e-6 <= o[i, jj] <= max(vals) + 1e-6
    assert counts["none"] == 15 and counts["some"] > 0
    with pytest.raises(ValueError, match="crop_size"):
        crop_resize(jnp.asarray(d), jnp.asarray(k), GGCNNConfig(input_size=24, crop_size=48))


# ----------------------------------------------------------------------------- post-processing


def test_gaussian_blur_matches_scipy():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(2, 20, 28)).astype(np.float32)
    for sigma in (1.0, 2.0):
        ref = np.stack([ndimage.gaussian_filter(xi, sigma, mode="reflect", truncate=4.0) for xi in x])
        np.testing.assert_allclose(np.asarray(gaussian_blur(jnp.asarray(x), sigma)), ref, atol=1e-5)


def test_peak_lands_on_planted_maximum():
    rng = np.random.default_rng(1)
    q = rng.uniform(0, 0.3, size=(3, 30, 40)).astype(np.float32)
    planted = [(5, 7), (33, 22), (20, 0)]  # (u, v)
    vv, uu = np.mgrid[0:30, 0:40]
    for b, (u, v) in enumerate(planted):
        q[b] += np.exp(-((uu - u) ** 2 + (vv - v) ** 2) / (2 * 1.5 ** 2))
    maps = GraspMaps(jnp.asarray(q), jnp.ones_like(q), jnp.zeros_like(q), jnp.full_like(q, 0.1))
    g = best_grasp(maps)
    assert g.pixel.tolist() == [list(p) for p in planted]
    np.testing.assert_allclose(np.asarray(g.angle), 0.0, atol=1e-6)
    np.testing.assert_allclose(np.asarray(g.width_px), 15.0, rtol=1e-5)
    assert peak(jnp.asarray(q)).tolist() == [list(p) for p in planted]


def test_label_peak_is_a_grasp_the_labels_hold():
    # Two 3 x 3 positives one row apart (theta 0 / 90 deg, length 6 -> 2 px along, jaw 3 -> 3 px
    # across): A = u 9..11, v 9..11 (angle 0), B = u 9..11, v 13..15 (angle pi/2).  Smoothed
    # with sigma 2 (g(d) = exp(-d^2 / 8): 1, .882, .607, .325, .135), the gap row v = 12 sums
    # 2 (g1 + g2 + g3) = 3.63 against 3.55 at v = 11 (g0 + g1 + g2 + g2 + g3 + g4): the
    # smoothed peak alone is (10, 12), a grasp nobody tried, whose angle averages 0 and 90 deg.
    c = cands(center=[[10, 10], [10, 14]], angle=[0.0, math.pi / 2], length=[6, 6], jaw=[3, 3],
              success=[True, True])
    maps = jax.tree.map(lambda a: a[None], label_maps(c, 24, 24))
    g = best_grasp(maps)  # the default post-processing
    u, v = (int(i) for i in g.pixel[0])
    assert float(maps.quality[0, v, u]) == 1.0, (u, v)
    # The pixel next to the gap in A or B, with that grasp's own angle.
    want = {(10, 11): 0.0, (10, 13): math.pi / 2}
    assert (u, v) in want
    assert abs(math.remainder(float(g.angle[0]) - want[(u, v)], math.pi)) < 1e-6


def test_label_peak_keeps_its_own_angle():
    # A: theta 0, length 12 -> |du| <= 2, jaw 5 -> |dv| <= 2.5: u 8..12, v 8..12.  B: one pixel
    # (14, 10) at 45 deg (cos 2theta = 0, sin 2theta = 1).  The peak lies inside A, whose label
    # angle is 0; smoothing cos / sin (GG-CNN's sigma 2) would add B's sin > 0 there.
    c = cands(center=[[10, 10], [14, 10]], angle=[0.0, math.pi / 4], length=[12, 3], jaw=[5, 1],
              success=[True, True])
    maps = jax.tree.map(lambda a: a[None], label_maps(c, 24, 24))
    g = best_grasp(maps)
    u, v = (int(i) for i in g.pixel[0])
    assert 8 <= u <= 12 and 8 <= v <= 12
    assert abs(float(g.angle[0])) < 1e-6
    assert float(g.width_px[0]) == pytest.approx(12.0, rel=1e-5)  # length 12 px, width map 12 / 150


def test_grasp_never_in_a_depth_hole():
    from vags_jax.ggcnn.planner import predict_grasp

    # A 12 x 12 camera at 0.5 m, the network at 12 x 12 (crop 12, scale 1: pixels map 1:1).
    # Pixel (3, 4) is a hole (depth 0, inpainted to 0.5 m); the maps' best quality sits there.
    cam = Camera(width=12, height=12, fx=20.0, fy=20.0)
    gcfg = GGCNNConfig(input_size=12, quality_sigma=0.0)
    depth = np.full((1, 12, 12), 0.5, np.float32)
    depth[0, 4, 3] = 0.0
    q = np.zeros((1, 12, 12), np.float32)
    q[0, 4, 3], q[0, 8, 8] = 1.0, 0.6

    class Fixed:  # a "network" that returns these maps
        def apply(self, params, x):
            return GraspMaps(jnp.asarray(q), jnp.ones_like(x), jnp.zeros_like(x), jnp.zeros_like(x))

    world, img = predict_grasp(Fixed(), None, jnp.asarray(depth), jnp.eye(4)[None], cam, gcfg, 0.0)
    assert img.pixel.tolist() == [[8, 8]]
    # cx = cy = 6: (8 - 6) * 0.5 / 20 = 0.05 m.
    np.testing.assert_allclose(np.asarray(world.position[0]), [0.05, 0.05, 0.5], atol=1e-6)
    # With no valid pixel at all, the mask is dropped rather than every pixel.
    none = best_grasp(GraspMaps(jnp.asarray(q), *(jnp.zeros_like(jnp.asarray(q)),) * 3), gcfg,
                      jnp.zeros((1, 12, 12), bool))
    assert none.pixel.tolist() == [[3, 4]]


def _rz(yaw):
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]], np.float32)


def test_peak_to_world_grasp_by_hand():
    # Camera 0.25 m above (0.1, 0.2, 0.05) looking straight down, turned 90 deg about world z:
    # image columns (camera x) run along world +y, image rows (camera y) along world +x.
    size, f = 48, 60.0
    cam = Camera(width=size, height=size, fx=f, fy=f)  # cx = cy = 24
    k = cam_lib.intrinsics(cam)
    pose = cam_lib.make_pose(_rz(math.pi / 2) @ cam_lib.DOWN_ROTATION, (0.1, 0.2, 0.30))
    theta = math.pi / 6  # closing axis 30 deg from +u towards +v
    u0, v0 = 28, 22
    vv, uu = np.mgrid[0:size, 0:size]
    q = np.exp(-((uu - u0) ** 2 + (vv - v0) ** 2) / 8.0)[None].astype(np.float32)
    maps = GraspMaps(jnp.asarray(q), jnp.full_like(q, math.cos(2 * theta)),
                     jnp.full_like(q, math.sin(2 * theta)), jnp.full_like(q, 6 / 150))
    g = best_grasp(maps)
    assert g.pixel.tolist() == [[u0, v0]]
    assert float(g.angle[0]) == pytest.approx(theta, abs=1e-5)
    assert float(g.width_px[0]) == pytest.approx(6.0, rel=1e-5)
    depth = jnp.full((1, size, size), 0.25, jnp.float32)
    wg = grasp_to_world(g.pixel, g.angle, g.width_px, sample_depth(depth, g.pixel), k, pose)
    # By hand: camera-frame point 0.25 * (4 / 60, -2 / 60, 1) = (1/60, -1/120, 0.25); looking
    # down flips y and z -> (1/60, 1/120, -0.25); the 90 deg turn maps (x, y) -> (-y, x).
    np.testing.assert_allclose(np.asarray(wg.position[0]), [0.1 - 1 / 120, 0.2 + 1 / 60, 0.05], atol=1e-6)
    # Axis (cos 30, sin 30) in the image -> (cos 30, -sin 30) looking down (-30 deg) -> +90: 60 deg.
    assert float(wg.yaw[0]) == pytest.approx(math.pi / 3, abs=1e-5)
    assert float(wg.width[0]) == pytest.approx(6 * 0.25 / 60, rel=1e-5)  # 2.5 cm
    # The project's own projection sends the world point back to the same pixel and depth.
    uv, z = cam_lib.project(wg.position[:, None], pose, cam)
    np.testing.assert_allclose(np.asarray(uv[0, 0]), [u0, v0], atol=1e-4)
    assert float(z[0, 0]) == pytest.approx(0.25, abs=1e-6)
    # The plain straight-down pose: yaw = -theta; an axis at -80 deg gives +80 deg; an axis
    # at 80 deg gives -80 deg; batched over two grasps.
    down = cam_lib.straight_down_pose(jnp.array([[0.0, 0.0, 0.5], [0.0, 0.0, 0.5]]))
    wg2 = grasp_to_world(jnp.array([[24, 24], [24, 24]]), jnp.radians(jnp.array([-80.0, 80.0])),
                         jnp.array([10.0, 10.0]), jnp.array([0.5, 0.5]), k, down)
    np.testing.assert_allclose(np.degrees(np.asarray(wg2.yaw)), [80.0, -80.0], atol=1e-4)
    np.testing.assert_allclose(np.asarray(wg2.position), [[0, 0, 0], [0, 0, 0]], atol=1e-6)


# ----------------------------------------------------------------------------- augmentation


def _planted(size=48, center=(30.0, 20.0), theta=0.3, length=24.0, jaw=6.0):
    c = cands([center], [theta], [length], [jaw], [True])
    labels = label_maps(c, size, size)
    vv, uu = np.mgrid[0:size, 0:size]
    x = np.exp(-((uu - center[0]) ** 2 + (vv - center[1]) ** 2) / 4.0).astype(np.float32)
    return jnp.asarray(x), labels


def _moved(center, angle, zoom, size=48):
    """Where augment_sample sends the point `center` (u, v): c + R(angle) (p - c) / zoom."""
    c = (size - 1) / 2
    du, dv = center[0] - c, center[1] - c
    ca, sa = math.cos(angle), math.sin(angle)
    return c + (ca * du - sa * dv) / zoom, c + (sa * du + ca * dv) / zoom


def test_augment_quarter_turn_is_exact():
    x, labels = _planted()
    x2, lab2 = augment_sample(x, labels, math.pi / 2, 1.0)
    cu, cv = _moved((30.0, 20.0), math.pi / 2, 1.0)
    assert (cu, cv) == (27.0, 30.0)
    redrawn = label_maps(cands([[cu, cv]], [0.3 + math.pi / 2], [24.0], [6.0], [True]), 48, 48)
    np.testing.assert_array_equal(np.asarray(lab2.quality), np.asarray(redrawn.quality))
    for name in ("cos", "sin", "width"):
        np.testing.assert_allclose(np.asarray(getattr(lab2, name)), np.asarray(getattr(redrawn, name)), atol=1e-5)
    # The depth bump moved with the grasp.
    np.testing.assert_allclose(np.asarray(x2), np.rot90(np.asarray(x), k=-1), atol=1e-6)
    assert np.unravel_index(np.argmax(np.asarray(x2)), x2.shape) == (30, 27)


@pytest.mark.parametrize("angle, zoom", [(math.pi / 2, 0.5), (0.7, 0.8)])
def test_augment_zoom_and_any_angle_keep_grasp_consistent(angle, zoom):
    x, labels = _planted()
    x2, lab2 = augment_sample(x, labels, angle, zoom)
    cu, cv = _moved((30.0, 20.0), angle, zoom)
    redrawn = label_maps(cands([[cu, cv]], [0.3 + angle], [24.0 / zoom], [6.0 / zoom], [True]), 48, 48)
    q2, qr = np.asarray(lab2.quality) > 0, np.asarray(redrawn.quality) > 0
    assert (q2 & qr).sum() / (q2 | qr).sum() > 0.75  # nearest resampling vs redrawing
    inner = q2 & qr
    np.testing.assert_allclose(np.asarray(lab2.cos)[inner], math.cos(2 * (0.3 + angle)), atol=1e-5)
    np.testing.assert_allclose(np.asarray(lab2.sin)[inner], math.sin(2 * (0.3 + angle)), atol=1e-5)
    np.testing.assert_allclose(np.asarray(lab2.width)[inner], 24.0 / zoom / 150, rtol=1e-5)
    vpk, upk = np.unravel_index(np.argmax(np.asarray(x2)), x2.shape)
    assert abs(upk - cu) <= 1 and abs(vpk - cv) <= 1


def test_augment_batch_from_key():
    cfg = GGCNNConfig(input_size=48)
    x, labels = _planted()
    xb = jnp.stack([x] * 4)
    lb = jax.tree.map(lambda a: jnp.stack([a] * 4), labels)
    key = jax.random.PRNGKey(3)
    x2, lab2 = jax.jit(augment_batch, static_argnums=3)(key, xb, lb, cfg)
    angles, zooms = sample_augmentation(key, 4, cfg)
    turns = np.asarray(angles) / (math.pi / 2)
    np.testing.assert_allclose(turns, np.round(turns), atol=1e-6)
    assert set(np.round(turns).astype(int).tolist()) <= {0, 1, 2, 3}
    assert np.all((np.asarray(zooms) >= 0.5) & (np.asarray(zooms) <= 1.0))
    for b in range(4):
        a, z = float(angles[b]), float(zooms[b])
        cu, cv = _moved((30.0, 20.0), a, z)
        q = np.asarray(lab2.quality[b]) > 0
        vs, us = np.nonzero(q)
        assert abs(us.mean() - cu) < 1.0 and abs(vs.mean() - cv) < 1.0
        np.testing.assert_allclose(np.asarray(lab2.cos[b])[q], math.cos(2 * (0.3 + a)), atol=1e-5)
        np.testing.assert_allclose(np.asarray(lab2.sin[b])[q], math.sin(2 * (0.3 + a)), atol=1e-5)
    with pytest.raises(ValueError, match="square"):
        augment_batch(key, xb[:, :, :36], jax.tree.map(lambda a: a[:, :, :36], lb), cfg)


# ----------------------------------------------------------------------------- training


@pytest.fixture(scope="module")
def batch():
    """A fixed tiny batch: 2 smooth random depth images of 24 x 24 and their labels."""
    rng = np.random.default_rng(0)
    d = 0.5 + 0.05 * ndimage.gaussian_filter(rng.normal(size=(2, SMALL, SMALL)), 3)
    x, _, _ = preprocess_depth(jnp.asarray(d, jnp.float32))
    c = cands(
        center=[[[8, 9], [16, 14]], [[12, 12], [5, 18]]],
        angle=[[0.2, 1.2], [-0.6, 0.0]],
        length=[[18, 15], [21, 12]],
        jaw=[[6, 6], [6, 3]],
        success=[[True, True], [True, False]],
    )
    return x, label_maps(c, SMALL, SMALL)


def test_loss_is_sum_of_four_mse(model, params, batch):
    x, labels = batch
    loss, terms = ggcnn_loss(params, model, x, labels)
    pred = model.apply(params, x)
    by_hand = sum(np.mean((np.asarray(getattr(pred, n)) - np.asarray(getattr(labels, n))) ** 2)
                  for n in ("quality", "cos", "sin", "width"))
    assert float(loss) == pytest.approx(by_hand, rel=1e-5)
    assert set(terms) == {"quality", "cos", "sin", "width"}
    w = jnp.asarray(np.random.default_rng(3).uniform(size=x.shape), jnp.float32)
    weighted, _ = ggcnn_loss(params, model, x, labels, w)
    by_hand = sum(np.mean(np.asarray(w) * (np.asarray(getattr(pred, n)) - np.asarray(getattr(labels, n))) ** 2)
                  for n in ("quality", "cos", "sin", "width"))
    assert float(weighted) == pytest.approx(by_hand, rel=1e-5)
    bad = jax.tree.map(lambda a: a[:, :12], labels)
    with pytest.raises(ValueError, match="labels must be"):
        ggcnn_loss(params, model, x, bad)


def test_adam_steps_reduce_loss(model, batch):
    # The input of this batch carries little (smooth noise), so what 20 steps can learn is the
    # maps' overall levels: from the initial 0.19 down to about their variance (0.09).  lr 1e-2
    # gets there in 20 steps (the default 1e-3 needs about 60).
    cfg = GGCNNConfig(input_size=SMALL, learning_rate=1e-2)
    state = init_train_state(jax.random.PRNGKey(1), cfg, model)
    step = make_train_step(cfg, model, augment=False)
    x, labels = batch
    key = jax.random.PRNGKey(2)
    losses = []
    for _ in range(20):
        state, metrics = step(state, key, x, labels)
        losses.append(float(metrics["loss"]))
    final, _ = ggcnn_loss(state.params, model, x, labels)
    assert int(state.step) == 20
    assert float(final) < 0.6 * losses[0], (losses[0], float(final))
    assert losses[-1] < losses[0]
    # With augmentation the step runs and gives a finite loss.
    aug_step = make_train_step(cfg, model, augment=True)
    state2, metrics = aug_step(state, jax.random.PRNGKey(4), x, labels)
    assert np.isfinite(float(metrics["loss"])) and int(state2.step) == 21


@pytest.mark.parametrize("k, s, p", [(3, 2, 1), (5, 2, 2), (9, 3, 3)])
def test_subpixel_transposed_conv_equals_flax_conv_transpose(k, s, p):
    """GG-CNN's three transposed convolutions, phase by phase, against lax.conv_transpose on the
    dilated input (what flax's nn.ConvTranspose computes), on a non-square input."""
    from vags_jax.nets.ggcnn import conv_transpose_subpixel

    pad = (k - 1 - p, k - 1 - p + 1)
    x = jax.random.normal(jax.random.PRNGKey(0), (2, 7, 9, 3))
    w = jax.random.normal(jax.random.PRNGKey(1), (k, k, 3, 4))
    ref = jax.lax.conv_transpose(x, w, (s, s), (pad, pad), dimension_numbers=("NHWC", "HWIO", "NHWC"))
    got = conv_transpose_subpixel(x, w, s, pad)
    assert got.shape == ref.shape
    np.testing.assert_allclose(np.asarray(got), np.asarray(ref), atol=1e-4)
    # The whole network: the same parameters give the same maps either way.
    model, dilated = GGCNN(), GGCNN(subpixel=False)
    params = init_ggcnn(jax.random.PRNGKey(2), model, size=24)
    xin = jax.random.normal(jax.random.PRNGKey(3), (1, 24, 24)) * 0.1
    a, b = model.apply(params, xin), dilated.apply(params, xin)
    np.testing.assert_allclose(np.asarray(a.stack()), np.asarray(b.stack()), atol=1e-5)
