"""The pure-JAX ray caster against MuJoCo C's mj_ray, colours, masks, batching, depth noise."""
import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest

import render_scenes as rs
from vags_jax.perception import camera, render
from vags_jax.config import DepthNoise, Workspace

CAM = rs.small_camera(0.1)  # 64 x 48, same field of view as 640 x 480
WS = Workspace()


def _viewpoint(xy_top):
    """Viewpoint pose above world point (x, y, surface_z) via a synthetic heightmap."""
    x, y, top = xy_top
    pix = np.asarray(camera.world_xy_to_pixel(np.array([x, y]), WS))
    hm = np.zeros((WS.heightmap_px, WS.heightmap_px), np.float32)
    hm[pix[0], pix[1]] = top
    return np.asarray(camera.viewpoint_pose(pix, hm, WS, CAM))


@pytest.fixture(scope="module")
def scene():
    m, d = rs.load(rs.clutter_xml())
    geometry = render.prepare_geometry(m)
    poses = np.stack([
        np.asarray(camera.global_pose(CAM)),
        _viewpoint((0.12, 0.11, 0.05)),  # above the convex prism
        _viewpoint((0.0, 0.15, 0.04)),  # above the capsule
        np.asarray(camera.look_at((0.25, 0.2, 0.3), (-0.02, 0.0, 0.02))),  # oblique, close
    ])
    b = len(poses)
    colors = render.model_colors(m, b)
    colors[1] = 255 - colors[1]  # a different palette in world 1
    fn = jax.jit(lambda xp, xm, c, p: render.render_full(geometry, xp, xm, c, p, CAM))
    xpos = np.broadcast_to(d.geom_xpos, (b,) + d.geom_xpos.shape)
    xmat = np.broadcast_to(d.geom_xmat.reshape(-1, 3, 3), (b, m.ngeom, 3, 3))
    out = jax.tree.map(np.asarray, fn(xpos, xmat, colors, poses))
    return dict(m=m, d=d, poses=poses, colors=colors, out=out, geometry=geometry)


def test_prepare_geometry_compiles_no_program():
    """The geometry tables go to the device by transfer, not by one small program per table
    (each is loaded from the compile cache in every eval.py and train.py process)."""
    from vags_jax.compile_cache import CompileClock

    m, _ = rs.load(rs.clutter_xml())
    with CompileClock() as clock:
        geometry = render.prepare_geometry(m)
    assert clock.backend == 0, clock.as_dict()
    assert geometry.polytopes and geometry.spheres is not None and geometry.cylinders is not None


def test_depth_matches_mj_ray(scene):
    """Within 1 mm of MuJoCo C's mj_ray (z-depth) on every pixel both hit, at 4 camera poses."""
    m, d, out = scene["m"], scene["d"], scene["out"]
    for i, pose in enumerate(scene["poses"]):
        ref, ref_geom = rs.mj_ray_depth(m, d, pose, CAM)
        ours = out.depth[i]
        ref_ok = np.isfinite(ref) & (ref >= CAM.near) & (ref <= CAM.far)
        both = ref_ok & (ours > 0)
        assert both.sum() > 0.5 * ours.size, i
        np.testing.assert_allclose(ours[both], ref[both], atol=1e-3, err_msg=f"pose {i}")
        # Hit / miss and the hit geom agree except on a few silhouette pixels.
        assert np.mean(ref_ok != (ours > 0)) <= 0.01, i
        assert np.mean(out.geom_id[i][both] == ref_geom[both]) >= 0.99, i
    # Every geom type of the scene was seen somewhere (box, mesh, plane, sphere, capsule, cylinder).
    seen = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) for g in np.unique(scene["out"].geom_id) if g >= 0}
    assert {"table", "cube", "prism", "wedge", "ball", "capsule", "can", "floor"} <= seen, seen


def test_mask_colours_and_batching(scene):
    m, out, colors = scene["m"], scene["out"], scene["colors"]
    gripper = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "gripper")
    assert not np.any(out.geom_id == gripper)  # group 3 is not rendered
    assert out.depth.dtype == np.float32 and out.rgb.dtype == np.uint8
    assert out.depth.shape == (4, CAM.height, CAM.width) and out.rgb.shape == (4, CAM.height, CAM.width, 3)
    hit = out.geom_id >= 0
    assert np.all(out.rgb[~hit] == 0) and np.all(out.depth[~hit] == 0)
    # Colour = per-world geom colour x shade in [AMBIENT, 1].
    base = np.take_along_axis(colors, np.maximum(out.geom_id, 0).reshape(4, -1, 1), axis=1).reshape(out.rgb.shape)
    lo = np.floor(base * render.AMBIENT) - 1
    assert np.all((out.rgb[hit] >= lo[hit]) & (out.rgb[hit] <= base[hit]))
    assert np.all((out.cos_incidence[hit] >= 0) & (out.cos_incidence[hit] <= 1 + 1e-6))
    # The top face of the table seen from straight above is fully lit.
    table = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "table")
    top = (out.geom_id[1] == table)
    assert top.any() and np.all(out.cos_incidence[1][top] > 0.8)


def test_unsupported_geom_and_mask_shape_errors():
    m, _ = rs.load('<mujoco><worldbody><geom type="ellipsoid" size=".1 .2 .3"/></worldbody></mujoco>')
    with pytest.raises(ValueError, match="ELLIPSOID"):
        render.prepare_geometry(m)
    with pytest.raises(ValueError, match="render_geom_mask"):
        render.prepare_geometry(m, np.ones(3, bool))
    with pytest.raises(ValueError, match="backend"):
        render.prepare_geometry(m, np.zeros(1, bool), backend="opengl")


def test_depth_noise():
    key = jax.random.PRNGKey(0)
    depth = jnp.full((2, 40, 50), 0.6).at[:, 0].set(0.0)
    cos = jnp.ones_like(depth).at[:, 1].set(0.1)  # row 1 seen at ~84 deg
    assert render.add_depth_noise(key, depth, cos, DepthNoise(enabled=False)) is depth  # disabled: identity
    cfg = DepthNoise(enabled=True, sigma_base=0.002, sigma_quadratic=0.0, disparity_step=0.0)
    noisy = np.asarray(render.add_depth_noise(key, depth, cos, cfg))
    assert np.all(noisy[:, 0] == 0) and np.all(noisy[:, 1] == 0)  # missing stays missing; grazing drops
    rest = noisy[:, 2:] - 0.6
    assert abs(rest.std() - 0.002) < 0.0003 and abs(rest.mean()) < 0.0003
    gone = render.add_depth_noise(key, depth, cos, DepthNoise(enabled=True, dropout_prob=1.0))
    assert np.all(np.asarray(gone) == 0)


def test_warp_backend_clear_error_without_gpu():
    if jax.default_backend() == "gpu":
        pytest.skip("on GPU the warp backend is tested separately")
    m, _ = rs.load(rs.one_box_xml())
    with pytest.raises(RuntimeError, match="warp"):
        render.prepare_geometry(m, backend="warp", cam_cfg=CAM, n_worlds=2)


def test_cos_incidence_at_matches_normals_from_depth(scene):
    """The Warp path's colours estimate normals from depth at the heightmap's source pixels
    only (`cos_incidence_at`): the same values as the whole-image `normals_from_depth`,
    image borders (where the differences wrap around) and holes included."""
    depth = scene["out"].depth.copy()
    depth[0, 10:14, 20:30] = 0.0  # a hole
    b, h, w = depth.shape
    full = np.asarray(render.normals_from_depth(jnp.asarray(depth), CAM)).reshape(b, -1)
    rng = np.random.default_rng(0)
    pix = rng.integers(0, h * w, size=(b, 300))
    pix[:, :4] = [0, w - 1, (h - 1) * w, h * w - 1]  # corners
    pix[0, 4:8] = [10 * w + 20, 11 * w + 25, 9 * w + 22, 14 * w + 29]  # in and next to the hole
    got = np.asarray(render.cos_incidence_at(jnp.asarray(depth), jnp.asarray(pix, jnp.int32), CAM))
    want = np.take_along_axis(full, pix, axis=1)
    np.testing.assert_allclose(got, want, atol=1e-6)
    assert (want[0, 4:6] == 0).all() and (want > 0.5).mean() > 0.5


def test_incidence_from_depth_and_segmentation_matches_exact_normals(scene):
    """The Warp path's incidence, estimated from depth and the renderer's segmentation, agrees
    with the ray caster's exact normals: differences stay on one geom, so pixels along an
    object's silhouette keep their own face's incidence.  Without the segmentation, central
    differences across depth jumps give grazing incidences there, which the sensor model drops
    as steep faces."""
    out = scene["out"]
    hit = out.depth > 0
    steep = np.cos(np.deg2rad(DepthNoise().grazing_dropout_deg))
    exact = out.cos_incidence
    seg = np.asarray(render.normals_from_depth(jnp.asarray(out.depth), CAM, jnp.asarray(out.geom_id)))
    plain = np.asarray(render.normals_from_depth(jnp.asarray(out.depth), CAM))
    err_seg, err_plain = np.abs(seg - exact)[hit], np.abs(plain - exact)[hit]
    flips_seg = ((seg < steep) != (exact < steep))[hit].mean()
    flips_plain = ((plain < steep) != (exact < steep))[hit].mean()
    # Measured at 64 x 48 px: 0.009 and 0.6 % with the segmentation, 0.074 and 9.5 % without.
    assert err_seg.mean() < 0.02 and flips_seg < 0.015, (err_seg.mean(), flips_seg)
    assert err_plain.mean() > 4 * err_seg.mean() and flips_plain > 5 * flips_seg, (err_plain.mean(), flips_plain)
    assert np.all(seg[~hit] == 0) and np.all((seg[hit] >= 0) & (seg[hit] <= 1 + 1e-6))
    # At chosen pixels only (the heightmap's source pixels): the same values.
    b, h, w = out.depth.shape
    pix = np.random.default_rng(1).integers(0, h * w, size=(b, 400)).astype(np.int32)
    pix[:, :4] = [0, w - 1, (h - 1) * w, h * w - 1]  # corners: neighbours outside the image are not used
    got = np.asarray(render.cos_incidence_at(jnp.asarray(out.depth), jnp.asarray(pix), CAM, jnp.asarray(out.geom_id)))
    np.testing.assert_allclose(got, np.take_along_axis(seg.reshape(b, -1), pix, axis=1), atol=1e-6)
