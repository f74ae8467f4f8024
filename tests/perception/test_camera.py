"""Camera geometry: intrinsics, poses, projection, heightmap cell <-> world maps."""
import jax.numpy as jnp
import numpy as np
import pytest

from vags_jax.perception import camera
from vags_jax.config import Camera, Workspace, tiny

CAM = Camera()
WS = Workspace()


def _assert_rigid(pose):
    pose = np.asarray(pose, np.float64)
    rot = pose[..., :3, :3]
    np.testing.assert_allclose(np.swapaxes(rot, -1, -2) @ rot, np.broadcast_to(np.eye(3), rot.shape), atol=1e-5)
    np.testing.assert_allclose(np.linalg.det(rot), 1.0, atol=1e-5)
    np.testing.assert_allclose(pose[..., 3, :], np.broadcast_to([0, 0, 0, 1], pose.shape[:-2] + (4,)))


def test_intrinsics_map_camera_points_to_pixels():
    """K sends a camera-frame point to its pixel, and `project` agrees.  Hand-computed with
    fx = 500, fy = 400, cx = 300.5, cy = 250: the point (0.1, -0.05, 0.5) lands at
    u = 500 * 0.1 / 0.5 + 300.5 = 400.5, v = 400 * -0.05 / 0.5 + 250 = 210."""
    cam = Camera(fx=500.0, fy=400.0, cx=300.5, cy=250.0)
    k = np.asarray(camera.intrinsics(cam), np.float64)
    point = np.array([0.1, -0.05, 0.5])
    np.testing.assert_allclose(k @ point / point[2], [400.5, 210.0, 1.0], rtol=1e-6)
    uv, z = camera.project(point[None], np.eye(4, dtype=np.float32), cam)  # camera frame = world
    np.testing.assert_allclose(np.asarray(uv)[0], [400.5, 210.0], rtol=1e-6)
    np.testing.assert_allclose(np.asarray(z), [0.5], rtol=1e-6)
    # With cx, cy unset the principal point is the image centre: the optical axis hits it.
    small = Camera(width=100, height=80, fx=90.0, fy=90.0)
    uv, _ = camera.project(np.array([[0.0, 0.0, 0.3]]), np.eye(4, dtype=np.float32), small)
    np.testing.assert_allclose(np.asarray(uv)[0], [50.0, 40.0], atol=1e-6)


def test_look_at_points_optical_axis_at_target():
    pos, tgt = np.array([0.3, -0.2, 0.5]), np.array([0.05, 0.1, 0.0])
    pose = camera.look_at(pos, tgt)
    _assert_rigid(pose)
    np.testing.assert_allclose(pose[:3, 3], pos, atol=1e-6)
    uv, z = camera.project(tgt[None], pose, CAM)
    np.testing.assert_allclose(uv[0], CAM.principal_point, atol=1e-3)
    assert z[0] > 0
    # Image "up" (-camera y) has a positive world-z component: the world is not upside down.
    assert -pose[2, 1] > 0
    # Batched.
    poses = camera.look_at(np.stack([pos, pos + 0.1]), tgt)
    assert poses.shape == (2, 4, 4)


@pytest.mark.parametrize("cam", [Camera(), tiny().camera], ids=["640x480", "tiny-128x96"])
def test_global_pose_sees_whole_workspace(cam):
    """From the preset global pose the workspace corners (on the table, with a margin of 5 px
    at 640 px width, and 10 cm above it) project inside the image, for the default camera and
    the ``tiny`` preset's."""
    pose = camera.global_pose(cam)
    _assert_rigid(pose)
    xmin, xmax, ymin, ymax = WS.bounds
    for z, margin in ((WS.table_z, 5.0 * cam.width / 640), (WS.table_z + 0.10, 0.0)):
        corners = np.array([[x, y, z] for x in (xmin, xmax) for y in (ymin, ymax)])
        uv, depth = camera.project(corners, pose, cam)
        uv = np.asarray(uv)
        assert np.all(np.asarray(depth) > cam.near)
        assert np.all(uv[:, 0] >= margin) and np.all(uv[:, 0] <= cam.width - 1 - margin), uv
        assert np.all(uv[:, 1] >= margin) and np.all(uv[:, 1] <= cam.height - 1 - margin), uv


def test_project_backproject_roundtrip():
    pose = camera.global_pose(CAM)
    depth = np.full((CAM.height, CAM.width), 0.7, np.float32)
    pts = camera.backproject(depth, CAM, pose)  # (h, w, 3)
    assert pts.shape == (CAM.height, CAM.width, 3)
    sel = np.asarray(pts)[::97, ::131].reshape(-1, 3)
    uv, z = camera.project(sel, pose, CAM)
    v, u = np.meshgrid(np.arange(0, CAM.height, 97), np.arange(0, CAM.width, 131), indexing="ij")
    np.testing.assert_allclose(np.asarray(uv), np.stack([u.ravel(), v.ravel()], -1), atol=2e-3)
    np.testing.assert_allclose(np.asarray(z), 0.7, atol=1e-5)
    # Pixel (u, v) samples the ray ((u - cx) / fx, (v - cy) / fy, 1).
    rays = np.asarray(camera.pixel_rays(CAM))
    np.testing.assert_allclose(rays[10, 20], [(20 - 320) / 618.62, (10 - 240) / 618.62, 1.0], rtol=1e-6)
    inv = camera.invert_pose(pose)
    np.testing.assert_allclose(np.asarray(inv @ pose), np.eye(4), atol=1e-6)


def test_heightmap_cells_and_world():
    xmin, xmax, ymin, ymax = WS.bounds
    px = WS.pixel_size
    cells = np.array([[0, 0], [0, 223], [223, 0], [100, 37]])
    xy = np.asarray(camera.pixel_to_world_xy(cells, WS))
    # row follows +y, col follows +x, cell centres.
    np.testing.assert_allclose(xy[0], [xmin + px / 2, ymin + px / 2], atol=1e-7)
    np.testing.assert_allclose(xy[1], [xmax - px / 2, ymin + px / 2], atol=1e-7)
    np.testing.assert_allclose(xy[2], [xmin + px / 2, ymax - px / 2], atol=1e-7)
    np.testing.assert_array_equal(np.asarray(camera.world_xy_to_pixel(xy, WS)), cells)
    out = camera.world_xy_to_pixel(np.array([[xmax + 0.001, 0.0], [0.0, ymin - 0.001]]), WS)
    assert not np.any(np.asarray(camera.in_workspace(out, WS)))


@pytest.mark.parametrize("viewpoint_height", [0.25, 0.4])
def test_viewpoint_pose_above_surface_looking_down(viewpoint_height):
    """The camera goes ``viewpoint_height`` (the paper's 25 cm, and another value) above the
    surface at the chosen cell, looking straight down at it."""
    cam = Camera(viewpoint_height=viewpoint_height)
    hm = np.zeros((2, WS.heightmap_px, WS.heightmap_px), np.float32)
    hm[0, 50, 120] = 0.07
    hm[1, 200, 10] = 0.0
    pix = np.array([[50, 120], [200, 10]])
    poses = np.asarray(camera.viewpoint_pose(pix, hm, WS, cam))
    assert poses.shape == (2, 4, 4)
    _assert_rigid(poses)
    xy = np.asarray(camera.pixel_to_world_xy(pix, WS))
    np.testing.assert_allclose(poses[:, :2, 3], xy, atol=1e-6)
    np.testing.assert_allclose(poses[:, 2, 3], [WS.table_z + 0.07 + viewpoint_height,
                                                WS.table_z + viewpoint_height], atol=1e-6)
    # Optical axis straight down; fixed orientation: image cols = world +x, image rows = world -y.
    np.testing.assert_allclose(poses[:, :3, 2], [[0, 0, -1]] * 2, atol=1e-7)
    np.testing.assert_allclose(poses[:, :3, 0], [[1, 0, 0]] * 2, atol=1e-7)
    np.testing.assert_allclose(poses[:, :3, 1], [[0, -1, 0]] * 2, atol=1e-7)
    # The surface point under the chosen cell projects to the principal point at depth
    # viewpoint_height; a point 1 cm along world +x lands 1 cm * fx / depth columns right of it.
    surface = np.array([[xy[0, 0], xy[0, 1], 0.07], [xy[0, 0] + 0.01, xy[0, 1], 0.07]])
    uv, z = camera.project(surface, poses[0], cam)
    cx, cy = cam.principal_point
    np.testing.assert_allclose(np.asarray(uv), [[cx, cy], [cx + 0.01 * cam.fx / viewpoint_height, cy]],
                               atol=1e-3)
    np.testing.assert_allclose(np.asarray(z), viewpoint_height, atol=1e-6)
    # Unbatched call.
    assert camera.viewpoint_pose(pix[0], hm[0], WS, cam).shape == (4, 4)


def _corner_margins(cam_cfg, ws):
    """Pixels between the workspace's table corners and the nearest image border (min over
    corners and borders), and the corners' rows."""
    h = ws.size / 2
    corners = jnp.array([[ws.center[0] + sx * h, ws.center[1] + sy * h, ws.table_z]
                         for sx in (-1, 1) for sy in (-1, 1)], jnp.float32)
    uv, z = camera.project(corners, camera.global_pose(cam_cfg), cam_cfg)
    uv = np.asarray(uv)
    assert (np.asarray(z) > 0).all()
    m = min(uv[:, 0].min(), cam_cfg.width - 1 - uv[:, 0].max(), uv[:, 1].min(), cam_cfg.height - 1 - uv[:, 1].max())
    return float(m), uv[:, 1]


def test_edge_variant_view_just_holds_the_workspace():
    """The "edge" scenes: the global camera on the default's line of sight, moved in until the
    workspace's near edge meets the image border (under 2 px to spare, every corner still in
    view), where the default keeps a wide margin; piles drop closer to the edges."""
    from vags_jax import config as C

    default, edge = C.preset("gpu"), C.preset("gpu-edge")
    m_default, _ = _corner_margins(default.camera, default.workspace)
    m_edge, rows = _corner_margins(edge.camera, edge.workspace)
    assert m_default > 40
    assert 0 <= m_edge < 2
    assert rows.max() > edge.camera.height - 3  # the near corners sit on the bottom border
    d_dir = np.asarray(default.camera.global_position) / np.linalg.norm(default.camera.global_position)
    e_dir = np.asarray(edge.camera.global_position) / np.linalg.norm(edge.camera.global_position)
    assert np.degrees(np.arccos(np.clip(d_dir @ e_dir, -1, 1))) < 0.2  # same line of sight
    assert edge.scene.drop_margin - edge.scene.pile_radius == pytest.approx(0.035)
    assert default.scene.drop_margin > edge.scene.drop_margin
