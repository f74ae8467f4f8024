"""``vags.close_score``: what the "gdnet" close-view planner maximizes after a move, on hand-made
maps and frames (GDNet's Q, or the success net's mean over a grasp and its half turn), and the
errors that say how to evaluate a run whose table was measured with the other score."""
from types import SimpleNamespace

import jax.numpy as jnp
import numpy as np
import pytest

from vags_jax import config as C
from vags_jax.perception import camera
from vags_jax.policies.decision import VagsNets, fused_grasp, half_turn_mean

CAM = C.Camera(width=64, height=48, fx=40.0, fy=40.0, near=0.05, far=2.0)
WS = C.Workspace(size=0.448, heightmap_px=32)  # 14 mm cells; a camera 25 cm up sees rows/cols ~5..26


def test_half_turn_mean_by_hand():
    q = jnp.arange(8, dtype=jnp.float32).reshape(1, 4, 1, 2)  # rotation r holds 2r, 2r + 1
    got = np.asarray(half_turn_mean(q))[0, :, 0]
    # r and r + 2 are one parallel-jaw grasp: (0, 1) & (4, 5) -> 2, 3; (2, 3) & (6, 7) -> 4, 5.
    np.testing.assert_allclose(got, [[2, 3], [4, 5], [2, 3], [4, 5]])
    with pytest.raises(ValueError, match="even number of grasp rotations"):
        half_turn_mean(q[:, :3])
    # Over half a turn (grasp.half_turn) no rotation repeats another's grasp: the mean is q,
    # odd counts included.
    np.testing.assert_array_equal(np.asarray(half_turn_mean(q, half_turn=True)), np.asarray(q))
    np.testing.assert_array_equal(np.asarray(half_turn_mean(q[:, :3], half_turn=True)), np.asarray(q[:, :3]))


def _flat_table_frame():
    """A straight-down close frame 25 cm above a flat table at the workspace centre, and empty
    global maps (1, 32, 32)."""
    pose = camera.straight_down_pose(jnp.array([0.0, 0.0, 0.25]))[None]
    depth = jnp.full((1, CAM.height, CAM.width), 0.25, jnp.float32)
    rgb = jnp.full((1, CAM.height, CAM.width, 3), 90, jnp.uint8)
    H = WS.heightmap_px
    return jnp.zeros((1, H, H, 3), jnp.uint8), jnp.zeros((1, H, H), jnp.float32), depth, rgb, pose


def _maps():
    """GDNet's map peaks at rotation 0, cell (16, 16).  The success net's: 0.9 at rotation 1,
    cell (12, 12) but 0.0 at its half turn (mean 0.45); 0.6 at rotations 1 and 3 of cell (20, 20)
    (mean 0.6); 1.0 at both rotations of cell (0, 0), which the close view does not see."""
    g = np.zeros((1, 4, 32, 32), np.float32)
    g[0, 0, 16, 16] = 5.0
    s = np.zeros((1, 4, 32, 32), np.float32)
    s[0, 1, 12, 12] = 0.9
    s[0, 1, 20, 20] = s[0, 3, 20, 20] = 0.6
    s[0, 1, 0, 0] = s[0, 3, 0, 0] = 1.0
    return (lambda c, h: jnp.asarray(g)), (lambda c, h: jnp.asarray(s))


def test_the_close_grasp_maximizes_the_configured_score_among_the_seen_cells():
    color, height, depth, rgb, pose = _flat_table_frame()
    gdnet_q, success_q = _maps()
    action, best, *_, seen = fused_grasp(color, height, depth, rgb, pose, CAM, WS, gdnet_q)
    assert np.asarray(action)[0].tolist() == [0, 16, 16] and float(best[0]) == pytest.approx(5.0)
    assert bool(seen[0, 20, 20]) and bool(seen[0, 12, 12]) and not bool(seen[0, 0, 0])
    action, best, *_ = fused_grasp(color, height, depth, rgb, pose, CAM, WS, gdnet_q, success_q=success_q)
    assert np.asarray(action)[0].tolist() == [1, 20, 20] and float(best[0]) == pytest.approx(0.6)
    action, _, *_ = fused_grasp(color, height, depth, rgb, pose, CAM, WS, gdnet_q, anywhere=True,
                                success_q=success_q)
    assert np.asarray(action)[0].tolist() == [1, 0, 0]  # "map": the unseen cell too
    # Over half a turn, rotations 1 and 3 are different grasps: the raw 0.9 at (12, 12) wins.
    action, best, *_ = fused_grasp(color, height, depth, rgb, pose, CAM, WS, gdnet_q, success_q=success_q,
                                   half_turn=True)
    assert np.asarray(action)[0].tolist() == [1, 12, 12] and float(best[0]) == pytest.approx(0.9)


def test_close_score_settings_that_cannot_work_say_what_to_fix():
    with pytest.raises(ValueError, match="vags.close_score must be one of"):
        C.replace(C.Config(), **{"vags.close_score": "gdnet"})
    with pytest.raises(ValueError, match="set vags.close_score=q or vags.local_planner=gdnet"):
        C.replace(C.Config(), **{"vags.local_planner": "ggcnn", "vags.close_score": "success"})
    with pytest.raises(ValueError, match="vags.train_close_score must be one of"):
        C.replace(C.Config(), **{"vags.train_close_score": "ggcnn"})
    with pytest.raises(ValueError, match="set vags.train_close_score=q or vags.local_planner=gdnet"):
        C.replace(C.Config(), **{"vags.local_planner": "ggcnn", "vags.train_close_score": "success"})
    cfg = C.replace(C.Config(), **{"vags.close_score": "success"})
    with pytest.raises(ValueError, match="--set vags.close_score=q"):
        VagsNets(cfg).close_success_q({"gdnet": {}})
    assert VagsNets(C.Config()).close_success_q({"gdnet": {}}) is None  # "q": GDNet scores them


def _networks(**kw):
    base = dict(success=(), ggcnn=None, q_threshold=np.float32(0.0), gdnet=None, vanet=None, calibration=None,
                gate_table=np.zeros((2, 1), np.float32), source="stage3 step 8", gate_estimate="grasp",
                gate_close_score="q")
    return SimpleNamespace(**{**base, **kw})


def test_a_table_measured_with_another_close_score_says_how_to_evaluate_it():
    from vags_jax.policies.catalog import vags_params
    cfg = C.replace(C.Config(), **{"vags.gate": "rate", "vags.close_score": "success"})
    with pytest.raises(ValueError, match="--set vags.close_score=q, or measure .* --close-score success"):
        vags_params(_networks(), cfg)
    assert "success" in vags_params(_networks(gate_close_score="success"), cfg)
    assert "gdnet" in vags_params(_networks(), cfg, threshold=-np.inf)  # the ablation never moves
    with pytest.raises(ValueError, match="have none: evaluate with --set vags.close_score=q"):
        vags_params(_networks(success=None, gate_close_score="success"),
                    C.replace(cfg, **{"vags.gate": "q"}))
