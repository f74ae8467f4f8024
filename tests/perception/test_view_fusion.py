"""Close views fused into the global heightmaps (``vags_jax.perception.view_fusion``), on hand-made frames.

A straight-down camera 25 cm above the table looks at a flat table with a 5 cm tall square
block under its centre; the global heightmap that it is fused into has a hole (0) where the
block is and a marker height elsewhere.  Everything is worked out from the geometry by hand.
"""
import jax.numpy as jnp
import numpy as np
import pytest

from vags_jax.perception import camera, view_fusion
from vags_jax import config as C

CAM = C.Camera(width=64, height=48, fx=40.0, fy=40.0, near=0.05, far=2.0)
WS = C.Workspace(size=0.448, heightmap_px=32)  # 14 mm cells
ALT = 0.25  # camera height above the table (m)
BLOCK = 0.05  # block height (m) and half-side 3 cm


def _frame(missing_block: bool = False):
    """(depth (1, h, w), rgb (1, h, w, 3), pose (1, 4, 4)): the block's top at depth ALT - BLOCK
    (red), the table at ALT (grey); ``missing_block``: the block's pixels have no depth."""
    pose = camera.straight_down_pose(jnp.array([0.0, 0.0, ALT]))
    pts = np.asarray(camera.backproject(jnp.full((CAM.height, CAM.width), ALT), CAM, pose))
    on_block = (np.abs(pts[..., 0]) < 0.03) & (np.abs(pts[..., 1]) < 0.03)
    depth = np.where(on_block, 0.0 if missing_block else ALT - BLOCK, ALT).astype(np.float32)
    rgb = np.where(on_block[..., None], [200, 0, 0], [90, 90, 90]).astype(np.uint8)
    return jnp.asarray(depth[None]), jnp.asarray(rgb[None]), pose[None]


def _cell(x, y):
    r, c = np.asarray(camera.world_xy_to_pixel(jnp.array([[x, y]], jnp.float32), WS))[0]
    return int(r), int(c)


def test_close_view_projects_block_and_table_heights():
    depth, rgb, pose = _frame()
    color, height, seen = view_fusion.close_heightmaps(depth, rgb, pose, CAM, WS)
    r, c = _cell(0.0, 0.0)
    assert bool(seen[0, r, c]) and float(height[0, r, c]) == pytest.approx(BLOCK, abs=1e-4)
    assert np.asarray(color[0, r, c]).tolist() == [200, 0, 0]
    # The table 6 cm from the centre, inside the footprint (half-width 0.25 * 32 / 40 = 0.2 m).
    r2, c2 = _cell(0.07, 0.0)
    assert bool(seen[0, r2, c2]) and float(height[0, r2, c2]) == pytest.approx(0.0, abs=1e-4)
    # Outside the footprint along y (half-height 0.25 * 24 / 40 = 0.15 m): not seen.
    r3, c3 = _cell(0.0, 0.2)
    assert not bool(seen[0, r3, c3])


def test_fuse_keeps_global_where_close_view_saw_nothing():
    depth, rgb, pose = _frame()
    H = WS.heightmap_px
    g_height = jnp.full((1, H, H), 0.123, jnp.float32)
    r, c = _cell(0.0, 0.0)
    g_height = g_height.at[0, r, c].set(0.0)  # an occlusion hole in the global map
    g_color = jnp.full((1, H, H, 3), 7, jnp.uint8)
    f_color, f_height, seen = view_fusion.fuse_close_view(g_color, g_height, depth, rgb, pose, CAM, WS)
    assert float(f_height[0, r, c]) == pytest.approx(BLOCK, abs=1e-4)  # the hole is filled
    assert np.asarray(f_color[0, r, c]).tolist() == [200, 0, 0]
    r3, c3 = _cell(0.0, 0.2)
    assert float(f_height[0, r3, c3]) == pytest.approx(0.123) and np.asarray(f_color[0, r3, c3]).tolist() == [7, 7, 7]
    unseen = ~np.asarray(seen[0])
    np.testing.assert_array_equal(np.asarray(f_height[0])[unseen], np.asarray(g_height[0])[unseen])


def test_missing_close_depth_keeps_the_global_height():
    """Pixels the sensor lost (depth 0) are no evidence: the global height stays there."""
    depth, rgb, pose = _frame(missing_block=True)
    H = WS.heightmap_px
    r, c = _cell(0.0, 0.0)
    g_height = jnp.zeros((1, H, H), jnp.float32).at[0, r, c].set(0.048)
    _, f_height, seen = view_fusion.fuse_close_view(jnp.zeros((1, H, H, 3), jnp.uint8), g_height, depth, rgb,
                                                    pose, CAM, WS)
    assert not bool(seen[0, r, c]) and float(f_height[0, r, c]) == pytest.approx(0.048)
