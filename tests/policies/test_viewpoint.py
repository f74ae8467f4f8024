"""Attempts with a viewpoint move: close views, motions, travel, and the GG-CNN policies.

Scenes are placed by hand (``Simulator.set_objects``) with two fixed blocks of the first
benchmark: a 10 cm tall one (``cuboid_tall``) and a 2.5 cm flat one (``cube_half``), seen by
the tiny preset's 128 x 96 camera without sensor noise.
"""
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from vags_jax.benchmark import metrics as M, protocol as E
from vags_jax.policies import catalog as P
from vags_jax.perception import camera
from vags_jax import config as C
from vags_jax.env import EnvState, VagsEnv, select_attempt
from vags_jax.nets.ggcnn import init_ggcnn

TALL, FLAT = 0, 1


@pytest.fixture(scope="module")
def cfg():
    # Pyramidal friction cones (conftest's PYRAMIDAL): the grasp programs compile faster, and
    # these checks hold on either cone.
    return C.replace(C.tiny(), **{
        "scene.shapes": ("cuboid_tall", "cube_half"), "scene.copies_per_shape": 1,
        "scene.max_objects": 2, "stage1.max_objects": 2, "stage2.max_objects": 2, "stage3.max_objects": 2, "scene.placement": "scatter",
        "scene.colour_jitter": 0.0, "camera.noise.enabled": False, "sim.cone": "pyramidal",
    })


@pytest.fixture(scope="module")
def env(cfg):
    e = VagsEnv(cfg)
    e.prepare(2)
    return e


def _scene(env, pos, active):
    """B worlds with objects resting unrotated at pos (B, 2, 3), active (B, 2), observed.

    Placed by teleport on an empty table, without a reset or a settle (fewer programs to
    compile): each block's centre is at half its height, so it rests as placed."""
    pos = np.asarray(pos, np.float32)
    B = pos.shape[0]
    quat = np.tile(np.array([1.0, 0, 0, 0], np.float32), (B, 2, 1))
    sim = env.sim.set_objects(env.sim.empty(B), pos, quat, np.asarray(active))
    H = env.cfg.workspace.heightmap_px
    zi = jnp.zeros((B,), jnp.int32)
    state = EnvState(sim=sim, color=jnp.zeros((B, H, H, 3), jnp.uint8), height=jnp.zeros((B, H, H)),
                     attempts=zi, successes=zi, motions=zi, travel=jnp.zeros((B,)))
    return env.with_observation(state)


def _cells(cfg, x0, x1, y0, y1):
    """Heightmap cells whose centres lie inside [x0, x1] x [y0, y1] -> (rows, cols)."""
    rc = np.stack(np.meshgrid(np.arange(cfg.workspace.heightmap_px), np.arange(cfg.workspace.heightmap_px),
                              indexing="ij"), -1).reshape(-1, 2)
    xy = np.asarray(camera.pixel_to_world_xy(rc, cfg.workspace))
    inside = (xy[:, 0] > x0) & (xy[:, 0] < x1) & (xy[:, 1] > y0) & (xy[:, 1] < y1)
    return rc[inside, 0], rc[inside, 1]


def test_close_view_sees_the_top_that_the_global_view_leaves_in_shadow(cfg, env):
    # The global camera looks from -y, 34 deg off vertical: the tall block (top 10 cm, back
    # face at y = 0.025) hides the table behind it up to y ~ 0.089 at 2.5 cm height, so the
    # whole top of the flat block behind it (y 0.035..0.085) is in its shadow.
    state = _scene(env, [[[0.0, 0.0, 0.05], [0.0, 0.06, 0.0125]]], [[True, True]])
    rows, cols = _cells(cfg, -0.018, 0.018, 0.042, 0.078)
    assert rows.size >= 4
    g = np.asarray(state.height[0])
    assert g[rows, cols].max() < 0.005, "the flat block's top should be unseen from the global pose"
    assert np.asarray(env.sim.object_positions(state.sim))[0, FLAT, 2] == pytest.approx(0.0125, abs=2e-3)
    # Move the camera above the flat block's centre cell: 25 cm above the (empty) global surface.
    pixel = jnp.asarray(camera.world_xy_to_pixel(jnp.array([[0.0, 0.06]]), cfg.workspace))
    pose = env.viewpoint_pose(state, pixel)
    assert np.allclose(np.asarray(pose[0, :3, 2]), [0, 0, -1], atol=1e-6)  # looking straight down
    _, close = env.observe(state.sim, pose)
    seen = np.asarray(close[0])[rows, cols]
    assert np.all(np.abs(seen - 0.025) < 0.004), seen
    # The raw close image shows the top 25 - 2.5 cm below the camera at its centre.
    image = env.camera_image(state.sim, pose)
    h, w = cfg.camera.height, cfg.camera.width
    centre = np.asarray(image.depth[0, h // 2 - 2:h // 2 + 2, w // 2 - 2:w // 2 + 2])
    assert np.allclose(centre, cfg.camera.viewpoint_height - 0.025, atol=2e-3)
    assert image.rgb.shape == (1, h, w, 3) and image.rgb.dtype == jnp.uint8


def test_topdown_oracle_sees_the_shadowed_top(cfg, env):
    """The ground-truth top-down maps (``vags_jax.perception.topdown``) show both tops at their true
    heights, the flat block's included, which the global view leaves in the tall one's shadow,
    and the bare table at 0."""
    from vags_jax.perception.topdown import TopDown

    state = _scene(env, [[[0.0, 0.0, 0.05], [0.0, 0.06, 0.0125]]], [[True, True]])
    color, height = jax.jit(TopDown(env).maps)(state.sim)
    h = np.asarray(height[0])
    flat = _cells(cfg, -0.018, 0.018, 0.042, 0.078)
    tall = _cells(cfg, -0.018, 0.018, -0.018, 0.018)
    table = _cells(cfg, 0.1, 0.2, -0.2, -0.1)
    assert flat[0].size >= 4 and tall[0].size >= 4
    np.testing.assert_allclose(h[flat], 0.025, atol=1e-3)
    np.testing.assert_allclose(h[tall], 0.10, atol=1e-3)
    np.testing.assert_allclose(h[table], 0.0, atol=1e-4)
    assert (np.asarray(color[0])[tall].max(axis=-1) > 0).all() and color.dtype == jnp.uint8


def test_viewpoint_attempt_counts_two_motions_and_starts_its_approach_at_the_viewpoint(cfg, env):
    # Two worlds, each an isolated flat block; world 0 moves the camera first, world 1 grasps
    # from the global view; both in one jitted call.
    xy = np.array([[0.08, -0.05], [-0.06, 0.07]], np.float32)
    pos = np.zeros((2, 2, 3), np.float32)
    pos[:, FLAT, :2], pos[:, FLAT, 2] = xy, 0.0125
    state = _scene(env, pos, [[False, True], [False, True]])
    grasp = jnp.asarray(np.concatenate([xy, np.full((2, 1), 0.0125 - cfg.grasp.depth_below_surface)], 1))
    yaw = jnp.zeros((2,))
    pixel = camera.world_xy_to_pixel(jnp.asarray(xy), cfg.workspace)
    view = env.viewpoint_pose(state, pixel)
    use_view = jnp.array([True, False])
    attempt = select_attempt(use_view, env.viewpoint_attempt(grasp, yaw, view), env.direct_attempt(grasp, yaw))
    s2, res = jax.jit(env.step_attempt)(state, attempt)
    assert np.asarray(s2.motions).tolist() == [2, 1]
    assert np.asarray(s2.attempts).tolist() == [1, 1]
    assert np.asarray(res.success).tolist() == [True, True]
    # The approach runs from where the last image was taken to 15 cm above the grasp point.
    g = cfg.grasp
    zg = np.maximum(np.asarray(grasp[:, 2]), cfg.workspace.table_z + g.min_height_above_table)
    pre = np.concatenate([xy, (zg + g.approach_height)[:, None]], 1)
    view_xyz = np.asarray(view[0, :3, 3])
    glob = np.asarray(cfg.camera.global_position)
    assert view_xyz[2] == pytest.approx(cfg.camera.viewpoint_height + np.asarray(state.height)[0, pixel[0, 0], pixel[0, 1]])
    approach = np.asarray(res.approach)
    assert approach[0] == pytest.approx(np.linalg.norm(pre[0] - view_xyz), rel=1e-5)
    assert approach[1] == pytest.approx(np.linalg.norm(pre[1] - glob), rel=1e-5)
    # Travel: the camera move (global -> viewpoint) + approach + descend + lift.
    move = np.linalg.norm(view_xyz - glob)
    expect = approach + g.approach_height + g.lift_height + np.array([move, 0.0])
    assert np.allclose(np.asarray(s2.travel), expect, rtol=1e-5)


def test_ggcnn_close_policy_counts_a_viewpoint_per_attempt(cfg):
    """The benchmark loop with ``ggcnn-close`` (an untrained GG-CNN: the mechanics, not the
    skill): every attempt moves the camera, so motions = 2 x attempts and viewpoint share 1."""
    from vags_jax.nets.ggcnn import init_ggcnn

    ecfg = C.replace(cfg, **{"benchmark.max_attempts_extra": 1})
    params = init_ggcnn(jax.random.PRNGKey(3), size=ecfg.ggcnn.input_size)
    policy = P.make_policy("ggcnn-close", ecfg, ggcnn_params=params)
    ev = E.Evaluator(ecfg)
    # Two worlds, the tall and the flat block apart (a scripted scene: no reset to compile).
    state = _scene(ev.env, [[[0.08, -0.05, 0.05], [-0.06, 0.07, 0.0125]]] * 2, [[True, True]] * 2)
    out = ev.play(policy, jax.random.PRNGKey(1), state)
    assert (out.n_objects == 2).all()
    assert (out.attempts >= 1).all() and (out.attempts <= 2 * 2 + 1).all()
    assert (out.motions == 2 * out.attempts).all()
    assert (out.viewpoints == out.attempts).all()
    np.testing.assert_array_equal(np.asarray(out.lost_after_move), out.lost)  # every loss came after a move
    np.testing.assert_array_equal(np.asarray(out.successes_after_move), out.successes)  # every grasp too
    m = M.summarize(out)
    assert m["viewpoint_rate"] == 1.0 and m["success_direct"] is None
    assert m["success_after_move"] == m["grasp_success_rate"]


def test_ggcnn_policies_need_parameters(cfg):
    for name in ("ggcnn", "ggcnn-close"):
        with pytest.raises(ValueError, match="needs trained GG-CNN parameters"):
            P.make_policy(name, cfg)


def test_ggcnn_grasp_refuses_a_wrong_depth_shape(cfg):
    from vags_jax.ggcnn.planner import predict_grasp
    from vags_jax.nets.ggcnn import GGCNN, init_ggcnn

    params = init_ggcnn(jax.random.PRNGKey(0), size=cfg.ggcnn.input_size)
    pose = jnp.eye(4)[None]
    with pytest.raises(ValueError, match=r"\(B, H, W\)"):
        predict_grasp(GGCNN(), params, jnp.ones((cfg.camera.height, cfg.camera.width)), pose, cfg.camera,
                      cfg.ggcnn, 0.03)


def test_decision_picks_each_branch_on_hand_set_q_maps():
    from vags_jax.policies.decision import decide

    B, R, H, W = 3, 4, 6, 5
    qg = np.zeros((B, R, H, W), np.float32)
    qv = np.zeros((B, H, W), np.float32)
    qg[0, 2, 4, 1] = 1.9   # world 0: confident grasp -> direct at (2, 4, 1)
    qg[1, 1, 0, 3] = 1.5   # world 1: below the threshold -> viewpoint at VANet's argmax
    qv[1, 5, 2] = 0.7
    qg[2, 3, 1, 1] = 1.78  # world 2: equal to the threshold is not above it -> viewpoint
    qv[2, 0, 4] = 0.2
    d = decide(jnp.asarray(qg), jnp.asarray(qv), 1.78)
    assert np.asarray(d.direct).tolist() == [True, False, False]
    assert np.asarray(d.grasp).tolist()[0] == [2, 4, 1]
    assert np.asarray(d.view).tolist()[1:] == [[5, 2], [0, 4]]
    assert np.allclose(np.asarray(d.q_max), [1.9, 1.5, 1.78])
    assert not np.asarray(decide(jnp.asarray(qg), jnp.asarray(qv), np.inf).direct).any()
    assert np.asarray(decide(jnp.asarray(qg), jnp.asarray(qv), -np.inf).direct).all()
    with pytest.raises(ValueError, match=r"VANet Q must be \(B, H, W\)"):
        decide(jnp.asarray(qg), jnp.asarray(qv[:, :-1]), 1.0)
    # viewpoint "grasp": the camera looks at GDNet's own argmax cell, not VANet's; the gate is unchanged.
    g = decide(jnp.asarray(qg), jnp.asarray(qv), 1.78, viewpoint="grasp")
    assert np.asarray(g.direct).tolist() == [True, False, False]
    assert np.asarray(g.view).tolist() == [[4, 1], [0, 3], [1, 1]]


def _one_direct_one_moving(cfg, env):
    """Two worlds of one block each and a hand-made decision: world 0 moves above its block, world
    1 grasps directly -> (state, Decision, the blocks' pixels (2, 2), a GDNet stand-in
    ``(color, height) -> (B, R, H, W)`` whose Q grows toward the heightmap's corner (0, 0) at
    rotation 2: its argmax over the whole map is (2, 0, 0), outside the close view above the block)."""
    from vags_jax.policies.decision import Decision

    xy = np.array([[0.08, -0.05], [-0.06, 0.07]], np.float32)
    pos = np.zeros((2, 2, 3), np.float32)
    pos[:, FLAT, :2], pos[:, FLAT, 2] = xy, 0.0125
    state = _scene(env, pos, [[False, True], [False, True]])
    pixel = camera.world_xy_to_pixel(jnp.asarray(xy), cfg.workspace)
    grasp = jnp.concatenate([jnp.array([[3], [5]], jnp.int32), pixel], 1)
    decision = Decision(direct=jnp.array([False, True]), grasp=grasp, view=pixel, q_max=jnp.array([1.0, 2.0]),
                        score=jnp.array([1.0, 2.0]))
    H = cfg.workspace.heightmap_px
    ramp = (2 * H - jnp.arange(H)[:, None] - jnp.arange(H)[None, :]).astype(jnp.float32)
    gdnet_q = lambda c, h: jnp.zeros((h.shape[0], cfg.net.n_rotations, H, H)).at[:, 2].set(ramp)  # noqa: E731
    return state, decision, pixel, gdnet_q


def test_the_close_pass_runs_on_the_moving_worlds_only(cfg, env):
    """``net.forward_needed_only``: the grasp after a move is planned by a pass over the worlds
    that move (here world 0 of 2, in groups of one world), and the attempts are those of the pass
    over every world."""
    from vags_jax.policies.decision import plan_attempt, q_in_groups

    state, decision, _, stand_in = _one_direct_one_moving(cfg, env)
    calls = []

    def one(c, h):
        jax.debug.callback(lambda: calls.append(1))
        return stand_in(c, h)

    gdnet_q = q_in_groups(one, 1)
    plans = {}
    for only in (False, True):
        pcfg = C.replace(cfg, **{"vags.local_planner": "gdnet", "net.forward_needed_only": only})
        calls.clear()
        plans[only] = plan_attempt(pcfg, env, state, decision, jax.random.PRNGKey(1), gdnet_q)
        jax.effects_barrier()
        assert len(calls) == (1 if only else 2)
    (a0, c0), (a1, c1) = plans[False], plans[True]
    for f in ("position", "yaw", "start", "motions"):
        np.testing.assert_array_equal(np.asarray(getattr(a1, f)), np.asarray(getattr(a0, f)))
    np.testing.assert_array_equal(np.asarray(c1.action[0]), np.asarray(c0.action[0]))


@pytest.mark.parametrize("planner,region", [("ggcnn", "seen"), ("gdnet", "seen"), ("gdnet", "map")])
def test_decision_plans_one_or_two_motions(cfg, env, planner, region):
    """plan_attempt on a hand-made decision: the direct world grasps GDNet's pixel from the
    global pose (1 motion); the other moves above VANet's pixel first (2 motions) and its
    approach starts there.  With the "gdnet" close-view planner the grasp after the move is
    GDNet's argmax among the cells the close view saw (``vags.close_region="seen"``) or on the
    whole fused map ("map"), at the fused map's height."""
    from vags_jax.policies.decision import plan_attempt

    pcfg = C.replace(cfg, **{"vags.local_planner": planner, "vags.close_region": region})
    state, decision, pixel, gdnet_q = _one_direct_one_moving(cfg, env)
    grasp = decision.grasp
    params = init_ggcnn(jax.random.PRNGKey(0), size=cfg.ggcnn.input_size)
    H = cfg.workspace.heightmap_px
    attempt, close = plan_attempt(pcfg, env, state, decision, jax.random.PRNGKey(1), gdnet_q, params)
    assert np.asarray(attempt.motions).tolist() == [2, 1]
    view = np.asarray(env.viewpoint_pose(state, pixel))[:, :3, 3]
    np.testing.assert_allclose(np.asarray(attempt.start[0]), view[0])
    np.testing.assert_allclose(np.asarray(attempt.start[1]), cfg.camera.global_position)
    direct_pos, direct_yaw = env.grasp_pose(state, grasp[:, 1:], grasp[:, 0])
    np.testing.assert_allclose(np.asarray(attempt.position[1]), np.asarray(direct_pos[1]))
    assert float(attempt.yaw[1]) == pytest.approx(float(direct_yaw[1]))
    assert float(attempt.view_travel[0]) == pytest.approx(float(np.linalg.norm(view[0] - cfg.camera.global_position)))
    assert float(attempt.view_travel[1]) == 0.0
    if planner == "gdnet" and region == "map":  # the ramp's corner, which the close view did not see
        assert np.asarray(close.action[0]).tolist() == [2, 0, 0] and not bool(close.seen[0, 0, 0])
    elif planner == "gdnet":
        seen = np.asarray(close.seen[0])
        rot, row, col = np.asarray(close.action[0]).tolist()
        assert 0 < seen.sum() < H * H and seen[row, col] and rot == 2
        # The corner-most seen cell: no seen cell has a larger ramp value.
        rows, cols = np.nonzero(seen)
        assert row + col == (rows + cols).min()
        assert (row, col) != (0, 0)
        surface = float(close.height[0, row, col])
        assert float(attempt.position[0, 2]) == pytest.approx(
            cfg.workspace.table_z + surface - cfg.grasp.depth_below_surface, abs=1e-6)
        assert float(attempt.yaw[0]) == pytest.approx(2 * cfg.grasp.rotation_step)


def test_success_gate_compares_estimates_on_hand_set_maps():
    """The "success" gate: direct where the success net's estimate at GDNet's argmax minus
    VANet's largest estimate exceeds -move_cost; the success net is read at GDNet's argmax,
    not at its own."""
    from vags_jax.policies.decision import decide, gate_threshold

    B, R, H, W = 3, 2, 4, 4
    qg = np.zeros((B, R, H, W), np.float32)
    qs = np.zeros((B, R, H, W), np.float32)
    qv = np.zeros((B, H, W), np.float32)
    for b in range(B):
        qg[b, 1, 2, 3] = 2.0  # GDNet's argmax (1, 2, 3) in every world
    qs[:, 1, 2, 3] = [0.9, 0.5, 0.6]  # p_direct
    qs[1, 0, 0, 0] = 0.99  # the success net's own argmax elsewhere: not what is executed
    qv[:, 1, 1] = [0.5, 0.8, 0.64]  # p_view
    thr = gate_threshold(C.Vags(gate="success", move_cost=0.05), None)
    d = decide(jnp.asarray(qg), jnp.asarray(qv), thr, jnp.asarray(qs), gate="success")
    np.testing.assert_allclose(np.asarray(d.score), [0.4, -0.3, -0.04], atol=1e-6)
    assert np.asarray(d.direct).tolist() == [True, False, True]  # world 2 gains 0.04 < 0.05: stays
    assert float(thr) == pytest.approx(-0.05)
    assert float(gate_threshold(C.Vags(gate="q"), 1.5)) == 1.5
    with pytest.raises(ValueError, match="success net"):
        decide(jnp.asarray(qg), jnp.asarray(qv), thr, None, gate="success")


def test_success_gate_subtracts_each_estimates_running_bias():
    """Calibration [direct, view] = each estimate's bias (estimate - outcome): an over-estimating
    VANet (bias 0.3) no longer wins a move it would win uncalibrated."""
    from vags_jax.policies.decision import decide, gate_score

    p_direct, p_view = jnp.array([0.7, 0.2]), jnp.array([1.1, 0.6])
    cal = jnp.array([-0.1, 0.3])  # the success net under-estimates by 0.1, VANet over-estimates by 0.3
    # By hand: (0.7 + 0.1) - (1.1 - 0.3) = 0.0 and (0.2 + 0.1) - (0.6 - 0.3) = 0.0; raw: -0.4 and -0.4.
    np.testing.assert_allclose(np.asarray(gate_score("success", None, p_direct, p_view, cal)), [0.0, 0.0], atol=1e-6)
    np.testing.assert_allclose(np.asarray(gate_score("success", None, p_direct, p_view)), [-0.4, -0.4], atol=1e-6)
    qg = np.zeros((1, 1, 2, 2), np.float32)
    qg[0, 0, 1, 1] = 1.0
    qs = np.full((1, 1, 2, 2), 0.7, np.float32)
    qv = np.array([[[0.0, 1.1], [0.0, 0.0]]], np.float32)
    moved = decide(jnp.asarray(qg), jnp.asarray(qv), -0.05, jnp.asarray(qs), "success")
    kept = decide(jnp.asarray(qg), jnp.asarray(qv), -0.05, jnp.asarray(qs), "success", cal)
    assert np.asarray(moved.direct).tolist() == [False] and np.asarray(kept.direct).tolist() == [True]


def test_calibration_tracks_estimate_minus_outcome_of_greedy_attempts():
    from vags_jax.policies.decision import update_calibration

    p_direct = jnp.array([0.9, 0.8, 0.5, 0.4])
    p_view = jnp.array([1.2, 1.0, 0.7, 0.9])
    success = jnp.array([True, False, True, False])
    direct = jnp.array([True, True, False, False])
    view = jnp.array([False, False, True, False])  # world 3 explored: not counted
    cal = update_calibration(jnp.array([0.2, 0.0, 0.6]), p_direct, p_view, success, direct, view, 0.5)
    # By hand: direct errors (0.9 - 1, 0.8 - 0) -> mean 0.35; 0.5 * 0.2 + 0.5 * 0.35 = 0.275.
    # View: one attempt, 0.7 - 1 = -0.3; 0.5 * 0 + 0.5 * -0.3 = -0.15.
    # Mean success after a move: that attempt succeeded; 0.5 * 0.6 + 0.5 * 1 = 0.8.
    np.testing.assert_allclose(np.asarray(cal), [0.275, -0.15, 0.8], atol=1e-6)
    none = jnp.zeros((4,), bool)
    same = update_calibration(jnp.array([0.2, -0.1, 0.6]), p_direct, p_view, success, none, none, 0.5)
    np.testing.assert_allclose(np.asarray(same), [0.2, -0.1, 0.6], atol=1e-6)  # no attempt: unchanged


def test_mean_view_estimate_replaces_vanets_value_by_the_runs_mean_success_after_a_move():
    """view_estimate "mean": every world's p_view is calibration[2], whatever VANet says; the
    direct estimate keeps its bias correction.  A 2-entry calibration (older runs) is refused."""
    from vags_jax.policies.decision import decide, gate_score, initial_calibration

    p_direct, p_view = jnp.array([0.9, 0.6, 0.75]), jnp.array([5.0, -3.0, 0.0])
    cal = jnp.array([0.1, 0.3, 0.7])
    # By hand: (0.9 - 0.1) - 0.7 = 0.1, (0.6 - 0.1) - 0.7 = -0.2, (0.75 - 0.1) - 0.7 = -0.05.
    np.testing.assert_allclose(np.asarray(gate_score("success", None, p_direct, p_view, cal, "mean")),
                               [0.1, -0.2, -0.05], atol=1e-6)
    # The same calibration with VANet's estimate: (0.8) - (5.0 - 0.3) etc.
    np.testing.assert_allclose(np.asarray(gate_score("success", None, p_direct, p_view, cal, "vanet")),
                               [0.8 - 4.7, 0.5 + 3.3, 0.65 + 0.3], atol=1e-5)
    with pytest.raises(ValueError, match="view_estimate=vanet"):
        gate_score("success", None, p_direct, p_view, cal[:2], "mean")
    # decide: VANet's largest value (9.0 in world 0) does not make world 0 move; a weak direct grasp does.
    qg = np.zeros((2, 1, 2, 2), np.float32)
    qg[:, 0, 1, 1] = 1.0
    qs = np.zeros((2, 1, 2, 2), np.float32)
    qs[:, 0, 1, 1] = [0.95, 0.5]
    qv = np.zeros((2, 2, 2), np.float32)
    qv[0, 0, 0] = 9.0
    d = decide(jnp.asarray(qg), jnp.asarray(qv), -0.05, jnp.asarray(qs), "success", jnp.array([0.0, 0.0, 0.8]), "mean")
    assert np.asarray(d.direct).tolist() == [True, False]
    # A stage starts optimistic about moves (so that a "mean" gate measures them), without bias.
    np.testing.assert_allclose(np.asarray(initial_calibration()), [0.0, 0.0, 1.0])


def test_view_reward_hand_cases():
    """VANet's reward.  "success": 1 when the grasp after the move succeeds, else 0.  "eq5"
    (reconstructed): 0 on failure whatever the Q values; 1 on success; 2 on success when
    GDNet's largest Q on the next view exceeds the one before the move."""
    from vags_jax.stages.stage23 import calibrated_threshold, view_reward

    success = jnp.array([False, False, True, True, True])
    before = jnp.array([1.0, 1.0, 1.5, 1.5, 1.5])
    after = jnp.array([0.5, 2.0, 1.2, 1.5, 1.9])
    assert np.asarray(view_reward(success, before, after, C.Vags())).tolist() == [0.0, 0.0, 1.0, 1.0, 1.0]
    eq5 = C.Vags(view_reward="eq5")
    assert np.asarray(view_reward(success, before, after, eq5)).tolist() == [0.0, 0.0, 1.0, 1.0, 2.0]
    no_bonus = C.Vags(view_reward="eq5", view_bonus=0.0, success_reward=0.5)
    assert np.asarray(view_reward(success, before, after, no_bonus)).tolist() == [0.0, 0.0, 0.5, 0.5, 0.5]
    q = jnp.array([1.0, 2.0, 3.0, 4.0, 5.0])
    assert float(calibrated_threshold(q, C.Vags())) == 3.0  # the median by default
    assert float(calibrated_threshold(q, C.Vags(threshold_quantile=1.0))) == 5.0
    assert float(calibrated_threshold(q, C.Vags(threshold=1.78))) == pytest.approx(1.78)
