"""Depth -> heightmaps: one box's top height, orientation, occlusion shadows, real-frame checks."""
import jax
import numpy as np
import pytest

import render_scenes as rs
from vags_jax.perception import camera, heightmap, render
from vags_jax.config import Workspace

WS = Workspace()  # full 224 x 224 at 2 mm


def _render(m, d, cam, poses, colors=None):
    geometry = render.prepare_geometry(m)
    b = len(poses)
    colors = render.model_colors(m, b) if colors is None else colors
    xpos = np.broadcast_to(d.geom_xpos, (b,) + d.geom_xpos.shape)
    xmat = np.broadcast_to(d.geom_xmat.reshape(-1, 3, 3), (b, m.ngeom, 3, 3))
    return jax.jit(lambda *a: render.render(geometry, *a, cam))(xpos, xmat, colors, np.asarray(poses))


def _rect_signed_distance(xy, center, half, yaw):
    """Signed distance (> 0 outside) of points (..., 2) to a rotated rectangle."""
    c, s = np.cos(yaw), np.sin(yaw)
    p = xy - center
    local = np.stack([c * p[..., 0] + s * p[..., 1], -s * p[..., 0] + c * p[..., 1]], -1)
    q = np.abs(local) - half
    return np.linalg.norm(np.maximum(q, 0), axis=-1) + np.minimum(q.max(-1), 0)


def test_one_box_top_height_and_footprint():
    """A box seen from straight above: its top height within 2 mm on its footprint cells
    (1-cell border excluded), 0 everywhere else; row = +y and col = +x."""
    size, pos, yaw = (0.03, 0.02, 0.025), (0.06, -0.04), 25.0
    m, d = rs.load(rs.one_box_xml(size, pos, yaw))
    top = 2 * size[2]
    cam = rs.small_camera(0.25)  # 160 x 120: ~0.65 mm per pixel at the box top, 2 mm cells
    pose = camera.straight_down_pose(np.array([pos[0], pos[1], top + 0.10]))
    depth, rgb = _render(m, d, cam, pose[None])
    color_hm, height_hm = heightmap.heightmaps(depth, rgb, pose[None], cam, WS)
    assert color_hm.shape == (1, 224, 224, 3) and color_hm.dtype == np.uint8
    assert height_hm.shape == (1, 224, 224) and height_hm.dtype == np.float32
    h, c = np.asarray(height_hm[0]), np.asarray(color_hm[0])
    rows, cols = np.meshgrid(np.arange(224), np.arange(224), indexing="ij")
    centres = np.asarray(camera.pixel_to_world_xy(np.stack([rows, cols], -1), WS))
    sd = _rect_signed_distance(centres, np.array(pos), np.array(size[:2]), np.deg2rad(yaw))
    border = WS.pixel_size * np.sqrt(2) / 2 + 1e-4  # a cell touches the edge within this
    inside, outside = sd < -border, sd > border
    assert inside.sum() > 200
    np.testing.assert_allclose(h[inside], top, atol=0.002)
    assert np.all(c[inside] > [100, -1, -1]) and np.all(c[inside][:, 1:] < 50)  # red box colour
    np.testing.assert_allclose(h[outside], 0.0, atol=1e-4)
    # Orientation: the box (at +x, -y) lies at high columns and low rows.
    r, cc = np.argwhere(h > 0.01).mean(0)
    assert cc > 112 and r < 112


def test_occlusion_shadow_and_viewpoint_removes_it():
    """A tall box near the far (+y) edge seen from the global camera (at -y) hides the table
    behind it: those cells get no point (black, height 0).  A viewpoint 25 cm above the box
    sees them (table colour)."""
    ws = Workspace(heightmap_px=56)  # 8 mm cells
    cam = rs.small_camera(0.5)  # 320 x 240
    half = (0.025, 0.025, 0.075)  # 15 cm tall
    box_xy = (0.0, 0.14)
    m, d = rs.load(rs.one_box_xml(half, box_xy, 0.0))
    g_pose = np.asarray(camera.global_pose(cam))
    # Viewpoint from the global heightmap's own height at the box centre (as VANet would).
    depth0, rgb0 = _render(m, d, cam, g_pose[None])
    color_g, height_g = heightmap.heightmaps(depth0, rgb0, g_pose[None], cam, ws)
    pix = np.asarray(camera.world_xy_to_pixel(np.array(box_xy), ws))
    v_pose = np.asarray(camera.viewpoint_pose(pix, height_g[0], ws, cam))
    np.testing.assert_allclose(v_pose[2, 3], 0.15 + 0.25, atol=0.003)
    depth1, rgb1 = _render(m, d, cam, v_pose[None])
    cx, cy = (int(v) for v in cam.principal_point)  # the optical axis hits the box top 25 cm away
    assert float(depth1[0, cy, cx]) == pytest.approx(0.25, abs=0.003)
    color_v, height_v = heightmap.heightmaps(depth1, rgb1, v_pose[None], cam, ws)
    color_g, color_v = np.asarray(color_g[0]), np.asarray(color_v[0])
    height_g, height_v = np.asarray(height_g[0]), np.asarray(height_v[0])
    xy = np.asarray(camera.pixel_to_world_xy(np.stack(np.meshgrid(np.arange(56), np.arange(56), indexing="ij"), -1), ws))
    behind = (np.abs(xy[..., 0] - box_xy[0]) < half[0] - 0.008) & (xy[..., 1] > box_xy[1] + half[1] + 0.008)
    beside = (np.abs(xy[..., 0] - box_xy[0]) > half[0] + 0.03) & (np.abs(xy[..., 1] - box_xy[1]) < half[1])
    assert behind.sum() >= 6 and beside.sum() >= 20
    no_point_g = np.all(color_g == 0, axis=-1)
    no_point_v = np.all(color_v == 0, axis=-1)
    assert np.all(no_point_g[behind]) and np.all(height_g[behind] == 0)  # the shadow
    assert not np.any(no_point_g[beside])  # sampling is dense: only the shadow is empty
    assert not np.any(no_point_v[behind])  # the viewpoint sees the table there
    np.testing.assert_allclose(height_v[behind], 0.0, atol=1e-4)
    # Both views see the box top.
    foot = (np.abs(xy[..., 0] - box_xy[0]) < half[0] - 0.008) & (np.abs(xy[..., 1] - box_xy[1]) < half[1] - 0.008)
    np.testing.assert_allclose(height_g[foot], 0.15, atol=0.002)
    np.testing.assert_allclose(height_v[foot], 0.15, atol=0.002)


def test_scatter_keeps_highest_point_and_drops_outside():
    """Hand-made depth: two pixels landing in the same cell -> the higher wins (with its colour);
    points outside the workspace and missing depth are dropped."""
    cam = rs.small_camera(0.025)  # 16 x 12
    ws = Workspace(heightmap_px=8, size=0.8)  # 10 cm cells
    pose = camera.straight_down_pose(np.array([0.02, 0.02, 1.0]))
    depth = np.zeros((1, cam.height, cam.width), np.float32)
    rgb = np.zeros((1, cam.height, cam.width, 3), np.uint8)
    cx, cy = (int(v) for v in cam.principal_point)
    depth[0, cy, cx], rgb[0, cy, cx] = 0.9, (10, 20, 30)  # point (0.02, 0.02, 0.1)
    depth[0, cy, cx + 1], rgb[0, cy, cx + 1] = 0.8, (40, 50, 60)  # (0.072, 0.02, 0.2): same cell
    depth[0, 0, 0], rgb[0, 0, 0] = 1.0, (255, 255, 255)  # (-0.50, 0.41): outside the 0.8 m square
    color, height = heightmap.heightmaps(depth, rgb, pose[None], cam, ws)
    height, color = np.asarray(height[0]), np.asarray(color[0])
    r, c = np.asarray(camera.world_xy_to_pixel(np.array([0.02, 0.02]), ws))
    assert height[r, c] == pytest.approx(0.2, abs=1e-5)
    assert tuple(color[r, c]) == (40, 50, 60)
    assert np.count_nonzero(height) == 1 and np.count_nonzero(color.any(-1)) == 1


def test_real_frame_validation():
    cam = rs.small_camera(0.05)  # 32 x 24
    ws = Workspace(heightmap_px=16)
    pose = np.asarray(camera.straight_down_pose(np.array([0.0, 0.0, 0.5])))
    depth = np.full((cam.height, cam.width), 0.45, np.float32)
    rgb = np.full((cam.height, cam.width, 3), 128, np.uint8)
    color, height = heightmap.heightmap_from_frame(depth, rgb, pose, cam, ws)
    assert isinstance(height, np.ndarray) and height.shape == (16, 16) and color.shape == (16, 16, 3)
    # NaN / inf depth -> missing.
    bad = depth.copy()
    bad[:] = np.nan
    with pytest.warns(heightmap.FrameWarning, match="valid"):  # no depth at all: said, not hidden
        _, h_nan = heightmap.heightmap_from_frame(bad, rgb, pose, cam, ws)
    assert np.all(h_nan == 0)
    cases = [
        (dict(depth=depth[:-1]), "expects"),
        (dict(depth=depth[None, None]), "2-D"),
        (dict(depth=(depth * 1000).astype(np.uint16)), "uint16|floating"),
        (dict(depth=depth * 1000), "millimetres"),
        (dict(depth=-depth), "negative"),
        (dict(rgb=rgb[..., :2]), "rgb must have shape"),
        (dict(rgb=rgb.astype(np.float32) / 255), "uint8"),
        (dict(cam_pose=pose[:3]), "cam_pose"),
        (dict(cam_pose=pose * np.array([1, 1, -1, 1])), "rigid"),
    ]
    for kw, msg in cases:
        args = dict(depth=depth, rgb=rgb, cam_pose=pose)
        args.update(kw)
        with pytest.raises(ValueError, match=msg):
            heightmap.heightmap_from_frame(args["depth"], args["rgb"], args["cam_pose"], cam, ws)


def test_heightmaps_refuse_batches_that_overflow_pixel_indices():
    """B * h * w >= 2**31 would wrap the scatter's int32 point indices: a clear error at trace
    time instead (checked on shapes only, nothing is allocated)."""
    cam = rs.small_camera(1.0)  # 640 x 480
    ws = Workspace()
    depth = jax.ShapeDtypeStruct((7000, cam.height, cam.width), np.float32)
    pose = jax.ShapeDtypeStruct((7000, 4, 4), np.float32)
    with pytest.raises(ValueError, match=r"at most 6990"):
        jax.eval_shape(lambda d, p: heightmap.height_and_source(d, p, cam, ws), depth, pose)
