"""A trained policy on RGB-D frames (``vags_jax.predict``: ``policy``, ``frames``, ``commands``): frames written
from the simulator go through the files a real camera would give, and the decision, the grasp
(global or after a viewpoint move) and its outcome in the simulator equal what ``eval.py``'s
``vags`` policy does on the same state.

The run is made by hand: its networks are a GDNet / VANet / success net whose trunks and head
have non-negative weights and whose colour trunk is zero, so that every Q value grows with the
height around a cell (the top of the tallest block wins); GG-CNN is untrained.  The scene is
placed by hand (``Simulator.set_objects``: no reset or settle to compile): a 10 cm tall block
and a 2.5 cm flat one beside it, seen by the tiny preset's 128 x 96 camera without sensor noise
(tests/policies/test_viewpoint.py's setting).  The bad inputs of the command line are in
``tests/test_bad_inputs.py``.
"""
import json
import math
import struct
import zlib

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from vags_jax import config as C
from vags_jax import predict
from vags_jax.benchmark.images import save_png
from vags_jax.env import EnvState, VagsEnv, select_attempt
from vags_jax.nets import make_qnet, variable_shapes
from vags_jax.nets.ggcnn import GGCNN
from vags_jax.perception import camera, heightmap
from vags_jax.policies import catalog, decision
from vags_jax.policies.decision import VagsNets
from vags_jax.predict import frames
from vags_jax.stages import checkpoint, rundir
from vags_jax.stages import ggcnn as ggcnn_stage

TALL_XY, FLAT_XY = (0.05, -0.03), (0.05, 0.03)
PLAN_KEY = jax.random.PRNGKey(9)  # the eval policy's key
THRESHOLDS = {"grasp": -1e6, "move": 1e6}  # the gate's threshold that forces each decision


@pytest.fixture(scope="module")
def cfg():
    """tests/policies/test_viewpoint.py's config (so that a whole test run compiles the grasp
    program once: the persistent compilation cache of conftest.py)."""
    # Pyramidal friction cones (conftest's PYRAMIDAL): the grasp programs compile faster, and
    # these checks hold on either cone.
    return C.replace(C.tiny(), **{
        "scene.shapes": ("cuboid_tall", "cube_half"), "scene.copies_per_shape": 1,
        "scene.max_objects": 2, "stage1.max_objects": 2, "stage2.max_objects": 2, "stage3.max_objects": 2,
        "scene.placement": "scatter", "scene.colour_jitter": 0.0, "camera.noise.enabled": False, "sim.cone": "pyramidal",
    })


def _filled(shapes, seed, kernel):
    """numpy values for a ShapeDtypeStruct tree (nothing compiled): kernel(name, shape) for
    kernels, BatchNorm scale / variance 1, every bias and mean 0."""
    rng = np.random.default_rng(seed)

    def fill(path, s):
        name = jax.tree_util.keystr(path)
        if name.endswith("['kernel']"):
            return kernel(name, s.shape, rng).astype(s.dtype)
        one = name.endswith("['scale']") or name.endswith("['var']")
        return np.full(s.shape, 1.0 if one else 0.0, s.dtype)
    return jax.tree_util.tree_map_with_path(fill, shapes)


def _monotone_kernel(name, shape, rng):
    """Binomial (near-Gaussian) positive weights and a zero colour trunk: every Q value is a
    centre-weighted sum of the heights around its cell, so the largest is the candidate cell
    nearest the middle of the tallest block."""
    if "colour_trunk" in name:
        return np.zeros(shape)
    b = [np.array([float(math.comb(n - 1, i)) for i in range(n)]) for n in shape[:2]]
    w = np.broadcast_to(np.outer(b[0], b[1])[:, :, None, None], shape)
    return w / w[..., 0].sum()


def _qnet_variables(cfg, kind, seed):
    H = cfg.workspace.heightmap_px
    return _filled(variable_shapes(make_qnet(cfg.net, kind), H, H), seed, _monotone_kernel)


def _ggcnn_params(seed):
    shapes = jax.eval_shape(GGCNN().init, jax.random.PRNGKey(0), jnp.zeros((1, 24, 24, 1)))
    return _filled(shapes, seed, lambda name, shape, rng: rng.normal(size=shape) * 0.1)


@pytest.fixture(scope="module")
def run(tmp_path_factory, cfg):
    """A run directory: config.json, stage 3's networks (GDNet, VANet, success net, threshold,
    calibration) and a GG-CNN."""
    d = str(tmp_path_factory.mktemp("predict") / "run")
    gd = _qnet_variables(cfg, "gdnet", 0)
    checkpoint.save_config(d, cfg)
    checkpoint.save(rundir.networks_dir(d, "stage3"), 4, {
        "gdnet": gd, "vanet": _qnet_variables(cfg, "vanet", 1), "success": gd, "threshold": np.float32(0.5),
        "calibration": np.array([0.01, -0.02, 0.7], np.float32)})
    ggcnn_stage.save_ggcnn(d, _ggcnn_params(3), {"steps": 0}, cfg)
    return d


@pytest.fixture(scope="module")
def env(cfg):
    e = VagsEnv(cfg)
    e.prepare(2)
    return e


@pytest.fixture(scope="module")
def scene(env, cfg):
    """(EnvState of one world, observed; the global camera image it was observed from)."""
    pos = np.array([[[*TALL_XY, 0.05], [*FLAT_XY, 0.0125]]], np.float32)
    quat = np.tile(np.array([1.0, 0, 0, 0], np.float32), (1, 2, 1))
    sim = env.sim.set_objects(env.sim.empty(1), pos, quat, np.array([[True, True]]))
    pose = env.global_poses(1)
    color, height = jax.jit(env.observe)(sim, pose)
    zi = jnp.zeros((1,), jnp.int32)
    state = EnvState(sim=sim, color=color, height=height, attempts=zi, successes=zi, motions=zi,
                     travel=jnp.zeros((1,)))
    return state, jax.jit(env.camera_image)(sim, pose)


@pytest.fixture(scope="module")
def policy(run):
    return predict.FramePolicy(run)


@pytest.fixture(scope="module")
def eval_plan(cfg, env, run):
    """eval.py's vags policy: its jitted planner and its params at each forced threshold."""
    nets = rundir.load_vags(run, cfg)
    plan = jax.jit(lambda p, k, s: catalog.vags_plan(cfg)(p, k, env, s))
    return plan, {k: catalog.vags_params(nets, cfg, t) for k, t in THRESHOLDS.items()}


def _camera(cfg):
    """The run's camera as a frame's K.json gives it (``frames.read_intrinsics``)."""
    return C.Camera(**frames.intrinsics_dict(cfg.camera))


def _frame(image, cfg):
    return predict.Frame(rgb=np.asarray(image.rgb[0]), depth=np.asarray(image.depth[0]),
                         pose=np.asarray(image.pose[0]), camera=_camera(cfg))


def _decide(policy, which, frame, close=None):
    policy.params = {**policy.params, "threshold": jnp.float32(THRESHOLDS[which])}
    return policy.decide(frame, close)


def _on_tall_block(grasp, cfg):
    """The grasp's cell shows the top of the tall block (10 cm, 5 cm square at TALL_XY): its
    surface (``depth_below_surface`` above the grasp centre) and its centre within a cell of
    the footprint."""
    x, y, z = grasp["position"]
    px = cfg.workspace.pixel_size
    assert abs(x - TALL_XY[0]) < 0.025 + px and abs(y - TALL_XY[1]) < 0.025 + px, grasp
    assert z + cfg.grasp.depth_below_surface == pytest.approx(0.10, abs=0.01), grasp
    return True


@pytest.fixture(scope="module")
def played(policy, eval_plan, scene, env, cfg):
    """Both decisions by predict and by the eval policy on the same state, and their grasps
    executed in the simulator: each side's [direct grasp, grasp after the move] in two copies
    of the state, one compiled step for both sides."""
    state, image = scene
    plan, params = eval_plan
    frame = _frame(image, cfg)
    direct = _decide(policy, "grasp", frame), plan(params["grasp"], PLAN_KEY, state)
    move = _decide(policy, "move", frame), plan(params["move"], PLAN_KEY, state)
    # The robot moves to the viewpoint and captures the close frame there.
    view = jnp.asarray(move[0]["viewpoint"]["camera_to_world"], jnp.float32)[None]
    after = _decide(policy, "move", frame, _frame(jax.jit(env.camera_image)(state.sim, view), cfg))
    two = jax.tree.map(lambda x: jnp.concatenate([x, x]) if x.ndim and x.shape[0] == 1 else x, state)
    step = jax.jit(env.step_attempt)
    evals = jax.tree.map(lambda a, b: jnp.concatenate([a, b]), direct[1].replace(score=None), move[1].replace(score=None))
    pos = jnp.asarray([direct[0]["grasp"]["position"], after["grasp"]["position"]], jnp.float32)
    yaw = jnp.asarray([direct[0]["grasp"]["yaw"], after["grasp"]["yaw"]], jnp.float32)
    views = jnp.concatenate([view, view])
    ours = select_attempt(jnp.array([False, True]), env.viewpoint_attempt(pos, yaw, views), env.direct_attempt(pos, yaw))
    results = [jax.tree.map(np.asarray, step(two, a)) for a in (evals, ours)]
    return {"direct": direct, "move": move, "after": after, "executed": results}


def _same_outcome(played, world):
    (s_eval, r_eval), (s_ours, r_ours) = played["executed"]
    assert r_eval.success[world] == r_ours.success[world] and r_eval.object[world] == r_ours.object[world]
    assert s_eval.travel[world] == s_ours.travel[world]
    assert s_eval.motions[world] == s_ours.motions[world] == world + 1
    np.testing.assert_array_equal(s_eval.height[world], s_ours.height[world])  # the next views


def test_frames_from_the_simulator_give_the_observed_heightmaps(scene, cfg, tmp_path):
    """The frame files hold the image the environment's observation was made from: read back
    (depth as float32 .npy), they project to exactly the observed heightmaps."""
    state, image = scene
    paths = frames.write_frame(str(tmp_path), image.rgb[0], image.depth[0], image.pose[0], cfg.camera,
                               cfg.workspace, depth_format="npy")
    f = predict.read_frame(paths["rgb"], paths["depth"], paths["intrinsics"], paths["pose"])
    assert f.camera == C.Camera(width=cfg.camera.width, height=cfg.camera.height, fx=cfg.camera.fx, fy=cfg.camera.fy,
                                cx=cfg.camera.width / 2, cy=cfg.camera.height / 2)
    color, height = heightmap.heightmap_from_frame(f.depth, f.rgb, f.pose, f.camera, cfg.workspace)
    np.testing.assert_array_equal(height, np.asarray(state.height[0]))
    np.testing.assert_array_equal(color, np.asarray(state.color[0]))
    assert frames.read_workspace(paths["workspace"]) == {
        "workspace.center": cfg.workspace.center, "workspace.size": cfg.workspace.size,
        "workspace.table_z": cfg.workspace.table_z, "workspace.heightmap_px": cfg.workspace.heightmap_px}


def test_direct_grasp_equals_the_eval_policy(played, cfg):
    """Threshold -1e6: a direct grasp on the top of the tall block, the eval policy's own, with
    the same outcome in the simulator."""
    out, attempt = played["direct"]
    assert out["decision"] == "grasp" and out["grasp"]["view"] == "global" and "viewpoint" not in out
    assert int(attempt.motions[0]) == 1
    np.testing.assert_array_equal(np.float32(out["grasp"]["position"]), attempt.position[0])
    assert np.float32(out["grasp"]["yaw"]) == attempt.yaw[0]
    assert _on_tall_block(out["grasp"], cfg)
    row, col = out["grasp"]["pixel"]
    xy = np.asarray(camera.pixel_to_world_xy(np.array([row, col]), cfg.workspace))
    np.testing.assert_allclose(out["grasp"]["position"][:2], xy, atol=1e-6)
    assert out["grasp"]["rotation"] * cfg.grasp.rotation_step == pytest.approx(out["grasp"]["yaw"], abs=1e-6)
    assert out["grasp"]["gripper_width"] == cfg.grasp.finger_stroke
    # The gate's figures: the success gate's score (calibrated estimates) against the threshold.
    gate = out["gate"]
    assert gate["kind"] == "success" and gate["threshold"] == -1e6 and gate["direct"] is True
    assert gate["calibration"] == pytest.approx([0.01, -0.02, 0.7]) and gate["view_estimate"] == "mean"
    assert gate["score"] == pytest.approx((gate["p_direct"] - 0.01) - 0.7, rel=1e-5)
    assert gate["score"] == pytest.approx(float(attempt.score[0]), rel=1e-6)
    assert "> threshold" in out["reason"]
    _same_outcome(played, 0)


def test_move_then_close_grasp_equals_the_eval_policy(played, cfg):
    """Threshold +1e6: a viewpoint (where the eval policy's camera moves); the frame taken there
    gives the close-view grasp ("gdnet": fused maps) the eval policy executes, same outcome."""
    out, attempt = played["move"]
    assert out["decision"] == "move" and "grasp" not in out and "<= threshold" in out["reason"]
    assert int(attempt.motions[0]) == 2
    view = np.asarray(out["viewpoint"]["camera_to_world"], np.float32)
    np.testing.assert_allclose(view[:3, 3], np.asarray(attempt.start[0]), atol=1e-6)
    assert np.allclose(view[:3, 2], [0, 0, -1], atol=1e-6)  # looking straight down
    np.testing.assert_allclose(out["viewpoint"]["looks_at"], view[:3, 3] - [0, 0, cfg.camera.viewpoint_height],
                               atol=1e-6)
    assert out["direct_grasp"]["view"] == "global"
    after = played["after"]
    assert after["decision"] == "grasp" and after["grasp"]["view"] == "close"
    assert after["viewpoint"] == out["viewpoint"] and after["gate"] == out["gate"]
    assert after["close_frame"]["distance_to_viewpoint_m"] == pytest.approx(0.0, abs=1e-6)
    assert after["close_frame"]["cells_seen"] > 0
    np.testing.assert_array_equal(np.float32(after["grasp"]["position"]), attempt.position[0])
    assert np.float32(after["grasp"]["yaw"]) == attempt.yaw[0]
    assert _on_tall_block(after["grasp"], cfg)
    _same_outcome(played, 1)


def test_the_q_gate_says_its_figures(run):
    """vags.gate=q: the run's stored Q threshold (0.5) against GDNet's largest Q."""
    pol = predict.FramePolicy(run, {"vags.gate": "q"})
    assert float(pol.params["threshold"]) == 0.5
    gate, reason = pol._gate({"score": np.array([0.25]), "direct": np.array([False]), "q_max": np.array([0.25])})
    assert gate == {"kind": "q", "score": 0.25, "threshold": 0.5, "direct": False, "q_max": 0.25}
    assert reason == "GDNet's largest Q 0.2500 <= threshold 0.5000: move the camera to the viewpoint"


def test_ggcnn_close_grasp_equals_the_eval_policy(run, scene, env, cfg):
    """vags.local_planner=ggcnn: GG-CNN's grasp in the close frame is the eval policy's."""
    state, image = scene
    over = {"vags.local_planner": "ggcnn"}
    gcfg = C.replace(cfg, **over)
    pol = predict.FramePolicy(run, over, threshold=1e6)
    frame = _frame(image, cfg)
    out = pol.decide(frame)
    view = jnp.asarray(out["viewpoint"]["camera_to_world"], jnp.float32)[None]
    after = pol.decide(frame, _frame(jax.jit(env.camera_image)(state.sim, view), cfg))
    params = catalog.vags_params(rundir.load_vags(run, gcfg), gcfg, 1e6)
    attempt = jax.jit(lambda p, k, s: catalog.vags_plan(gcfg)(p, k, env, s))(params, PLAN_KEY, state)
    g = after["grasp"]
    assert g["planner"] == "ggcnn" and g["view"] == "close" and int(attempt.motions[0]) == 2
    np.testing.assert_array_equal(np.float32(g["position"]), attempt.position[0])
    assert np.float32(g["yaw"]) == attempt.yaw[0]
    assert isinstance(g["quality"], float) and isinstance(g["predicted_width"], float)  # untrained: any value
    assert g["gripper_width"] == cfg.grasp.finger_stroke
    assert g["pixel"] == np.asarray(camera.world_xy_to_pixel(np.asarray(g["position"][:2]), cfg.workspace)).tolist()
    assert all(0 <= c < cfg.ggcnn.input_size for c in g["image_pixel"])


def _same_grasp_yaw(a, b) -> bool:
    """Two yaws of one parallel-jaw grasp: equal, or half a turn apart."""
    d = (float(a) - float(b) + math.pi / 2) % math.pi - math.pi / 2
    return abs(d) < 1e-5


def test_success_scored_close_grasp_equals_the_eval_policy(run, scene, env, cfg):
    """vags.close_score=success (the gpu presets'): the close frame's grasp is the argmax of the
    success net's half-turn mean on the fused maps, as the eval policy's, and says so.  The
    success net's last kernel is negated, so that it prefers the lowest cells and its grasp
    leaves the tall block GDNet would grasp.  Those cells are flat table, where grasps 90
    degrees apart score the same to the last bits or so: the two programs may round such a tie
    either way, so the grasp must be at the eval policy's cell and score the map's maximum."""
    state, image = scene
    over = {"vags.close_score": "success"}
    scfg = C.replace(cfg, **over)
    pol = predict.FramePolicy(run, over, threshold=1e6)
    flip = lambda path, x: -x if jax.tree_util.keystr(path).endswith("['head']['conv1']['kernel']") else x  # noqa: E731
    pol.params = {**pol.params, "success": jax.tree_util.tree_map_with_path(flip, pol.params["success"])}
    frame = _frame(image, cfg)
    view = jnp.asarray(pol.decide(frame)["viewpoint"]["camera_to_world"], jnp.float32)[None]
    g = pol.decide(frame, _frame(jax.jit(env.camera_image)(state.sim, view), cfg))["grasp"]
    params = {**catalog.vags_params(rundir.load_vags(run, scfg), scfg, 1e6), "success": pol.params["success"]}
    nets = VagsNets(scfg)
    attempt, _, close = jax.jit(lambda p, k, s: nets.plan(p, k, env, s)[:3])(params, PLAN_KEY, state)
    assert g["planner"] == "gdnet" and g["view"] == "close" and "q" not in g and isinstance(g["p_success"], float)
    np.testing.assert_array_equal(np.float32(g["position"]), attempt.position[0])
    assert g["pixel"] == np.asarray(close.action)[0, 1:].tolist()
    # The half-turn mean of the success net on the eval policy's fused maps, over the cells the
    # close view saw: both grasps at its maximum.
    score = np.asarray(decision.half_turn_mean(nets.close_success_q(params)(close.color, close.height)))[0]
    seen = np.asarray(close.seen)[0]
    assert seen.any() and scfg.vags.close_region != "map"
    score = np.where(seen[None], score, -np.inf)
    r_eval, row, col = np.asarray(close.action)[0].tolist()
    assert score[r_eval, row, col] == pytest.approx(score.max(), rel=1e-5, abs=1e-6)
    assert score[g["rotation"], row, col] == pytest.approx(score.max(), rel=1e-5, abs=1e-6)
    assert g["p_success"] == pytest.approx(float(score.max()), rel=1e-5, abs=1e-6)
    if abs(float(score.max()) - np.sort(score.ravel())[-3]) > 1e-5:  # one best grasp (its two rotations)
        assert _same_grasp_yaw(g["yaw"], attempt.yaw[0])
    reach = 0.025 + cfg.workspace.pixel_size
    assert abs(g["position"][0] - TALL_XY[0]) > reach or abs(g["position"][1] - TALL_XY[1]) > reach, g


def test_success_planned_direct_grasp_equals_the_eval_policy(run, scene, env, cfg):
    """vags.direct_score=success: the direct grasp is the argmax of the success net's half-turn
    mean on the global maps, as the eval policy's, and gives that value, not GDNet's Q.  The
    success net's last kernel is negated, so that its grasp leaves the tall block GDNet grasps."""
    state, image = scene
    over = {"vags.direct_score": "success"}
    scfg = C.replace(cfg, **over)
    pol = predict.FramePolicy(run, over, threshold=-1e6)
    flip = lambda path, x: -x if jax.tree_util.keystr(path).endswith("['head']['conv1']['kernel']") else x  # noqa: E731
    pol.params = {**pol.params, "success": jax.tree_util.tree_map_with_path(flip, pol.params["success"])}
    g = pol.decide(_frame(image, cfg))["grasp"]
    params = {**catalog.vags_params(rundir.load_vags(run, scfg), scfg, -1e6), "success": pol.params["success"]}
    attempt = jax.jit(lambda p, k, s: catalog.vags_plan(scfg)(p, k, env, s))(params, PLAN_KEY, state)
    assert g["view"] == "global" and "q" not in g and int(attempt.motions[0]) == 1
    np.testing.assert_array_equal(np.float32(g["position"]), attempt.position[0])
    q_success = VagsNets(scfg).q_maps(pol.params, state.color, state.height)[2]
    action = jnp.asarray([[g["rotation"], *g["pixel"]]], jnp.int32)
    want = decision.success_estimate(q_success, action, "symmetric")[0]
    assert g["p_success"] == pytest.approx(float(want), rel=1e-5, abs=1e-6)
    score = np.asarray(decision.half_turn_mean(q_success))[0]
    assert g["p_success"] == pytest.approx(float(score.max()), rel=1e-5, abs=1e-6)
    # The eval policy's grasp is at the same cell and at the maximum too; grasps that tie there to
    # the last bits (flat cells, turned 90 degrees) may be rounded apart by the two programs.
    r_eval = int(round(float(attempt.yaw[0]) / scfg.grasp.rotation_step)) % scfg.grasp.n_rotations
    assert score[(r_eval, *g["pixel"])] == pytest.approx(float(score.max()), rel=1e-5, abs=1e-6)
    if abs(float(score.max()) - np.sort(score.ravel())[-3]) > 1e-5:  # one best grasp (its two rotations)
        assert _same_grasp_yaw(g["yaw"], attempt.yaw[0])
    reach = 0.025 + cfg.workspace.pixel_size
    assert abs(g["position"][0] - TALL_XY[0]) > reach or abs(g["position"][1] - TALL_XY[1]) > reach, g


def test_no_viewpoint_on_a_stage1_run_is_gdnet_alone(run, policy, scene, cfg, tmp_path):
    """--no-viewpoint: a run with stage 1 alone grasps with its GDNet, as the VAGS run's
    direct grasp with the same GDNet."""
    state, image = scene
    s1 = str(tmp_path / "stage1")
    checkpoint.save_config(s1, cfg)
    learner = rundir.learner_target(cfg, "gdnet").replace(**_qnet_variables(cfg, "gdnet", 0))
    checkpoint.save(s1, 3, {"learner": learner})
    out = predict.FramePolicy(s1, no_viewpoint=True).decide(_frame(image, cfg))
    assert out["networks"] == out["gdnet"] == "stage1 step 3" and out["decision"] == "grasp"
    assert out["gate"]["kind"] == "none"
    direct = _decide(policy, "grasp", _frame(image, cfg))
    # The same grasp; its Q comes from two programs, which may round it apart in the last bit.
    assert {**out["grasp"], "q": None} == {**direct["grasp"], "q": None}
    assert out["grasp"]["q"] == pytest.approx(direct["grasp"]["q"], rel=1e-5, abs=1e-6)
    with pytest.raises(ValueError, match="with --no-viewpoint the policy never moves the camera"):
        predict.FramePolicy(s1, no_viewpoint=True).decide(_frame(image, cfg), _frame(image, cfg))
    # The success net's direct grasp needs stages 2-3: said before any network loads.
    with pytest.raises(ValueError, match="has stage 1 alone: drop that setting"):
        predict.FramePolicy(s1, {"vags.direct_score": "success"}, no_viewpoint=True)
    # GDNet alone on the mean of its two views of each grasp: that mean's maximum, and says so.
    frame = _frame(image, cfg)
    g = predict.FramePolicy(s1, {"vags.direct_score": "q_mean"}, no_viewpoint=True).decide(frame)["grasp"]
    color, height = heightmap.heightmaps(jnp.asarray(frame.depth)[None], jnp.asarray(frame.rgb)[None],
                                         jnp.asarray(frame.pose)[None], frame.camera, cfg.workspace)
    q = make_qnet(cfg.net, "gdnet").apply(_qnet_variables(cfg, "gdnet", 0), color, height, False)
    both = np.asarray(decision.half_turn_mean(q))[0]
    assert "q" not in g and g["q_mean"] == pytest.approx(float(both.max()), rel=1e-5, abs=1e-6)
    assert both[(g["rotation"], *g["pixel"])] == pytest.approx(float(both.max()), rel=1e-5, abs=1e-6)


def test_the_command_line_on_files(run, scene, cfg, tmp_path, capsys):
    """predict on the files write_frame makes (depth as a 16-bit millimetre PNG): one JSON
    object, the grasp on the tall block; --out-image draws it on the frame."""
    state, image = scene
    paths = frames.write_frame(str(tmp_path), image.rgb[0], image.depth[0], image.pose[0], cfg.camera, cfg.workspace)
    assert np.abs(frames.read_depth(paths["depth"]) - np.asarray(image.depth[0])).max() <= 0.0005 + 1e-6
    argv = ["--run", run, "--rgb", paths["rgb"], "--depth", paths["depth"], "--intrinsics", paths["intrinsics"],
            "--pose", paths["pose"], "--workspace", paths["workspace"], "--threshold", "-1000000",
            "--out-image", str(tmp_path / "decision.png")]
    assert predict.main(argv) == 0
    captured = capsys.readouterr()
    out = json.loads(captured.out)
    assert out["decision"] == "grasp" and _on_tall_block(out["grasp"], cfg)
    assert out["networks"] == "stage3 step 4" and out["gate"]["threshold"] == -1e6
    assert out["gdnet"].split(" ")[0] in ("stage3", "stage2")  # the GDNet its gate table kept
    drawn = frames.read_rgb(str(tmp_path / "decision.png"))
    assert drawn.shape == np.asarray(image.rgb[0]).shape
    changed = np.any(drawn != np.asarray(image.rgb[0]), axis=-1)
    assert 0 < changed.sum() < changed.size // 4  # a line, not the whole picture
    # The grasp's centre projects onto the drawn pixels.
    uv, _ = camera.project(np.asarray([out["grasp"]["position"]], np.float32)[None], image.pose[0], cfg.camera)
    u, v = np.round(np.asarray(uv)[0, 0]).astype(int)
    assert changed[max(v - 2, 0):v + 3, max(u - 2, 0):u + 3].any()


# ----------------------------------------------------------------------------- PNG files


def _png(path, rows: np.ndarray, bits: int, ctype: int, filters):
    """A PNG whose rows are filtered with the given filter types (PNG spec 9.2), to test the
    reader on files other encoders write.  rows (h, w * bytes per pixel) uint8."""
    h, stride = rows.shape
    bpp = {0: 1, 2: 3, 4: 2, 6: 4}[ctype] * bits // 8
    raw = rows.astype(np.int32)
    out = []
    for r in range(h):
        f = filters[r % len(filters)]
        up = raw[r - 1] if r else np.zeros(stride, np.int32)
        left = np.concatenate([np.zeros(bpp, np.int32), raw[r, :-bpp]])
        ul = np.concatenate([np.zeros(bpp, np.int32), up[:-bpp]])
        p = left + up - ul
        pa, pb, pc = np.abs(p - left), np.abs(p - up), np.abs(p - ul)
        paeth = np.where((pa <= pb) & (pa <= pc), left, np.where(pb <= pc, up, ul))
        pred = [0, left, up, (left + up) // 2, paeth][f]
        out.append(bytes([f]) + ((raw[r] - pred) & 0xFF).astype(np.uint8).tobytes())

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    w = stride // bpp
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, bits, ctype, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(b"".join(out))) + chunk(b"IEND", b""))


@pytest.mark.parametrize("filters", [[0], [1], [2], [3], [4], [0, 1, 2, 3, 4], [2, 0, 2]])
def test_png_reader_undoes_every_filter(filters, tmp_path):
    rng = np.random.default_rng(len(filters) * 7 + filters[0])
    rgb = rng.integers(0, 256, (9, 7, 3), dtype=np.uint8)
    _png(tmp_path / "c.png", rgb.reshape(9, -1), 8, 2, filters)
    np.testing.assert_array_equal(frames.read_png(str(tmp_path / "c.png")), rgb)
    depth = rng.integers(0, 65536, (5, 6), dtype=np.uint16)
    _png(tmp_path / "d.png", depth.astype(">u2").view(np.uint8).reshape(5, -1), 16, 0, filters)
    back = frames.read_png(str(tmp_path / "d.png"))
    assert back.dtype == np.uint16
    np.testing.assert_array_equal(back, depth)
    rgba = rng.integers(0, 256, (4, 5, 4), dtype=np.uint8)
    _png(tmp_path / "a.png", rgba.reshape(4, -1), 8, 6, filters)
    np.testing.assert_array_equal(frames.read_rgb(str(tmp_path / "a.png")), rgba[..., :3])


def test_png_reader_reads_what_pillow_writes(tmp_path):
    """Pillow (when installed: matplotlib brings it) picks its own filters and compression."""
    Image = pytest.importorskip("PIL.Image")
    yy, xx = np.mgrid[0:40, 0:50]
    rgb = np.stack([xx * 5, yy * 6, (xx * yy) % 256], -1).astype(np.uint8)
    depth = (300 + 10 * xx + yy).astype(np.uint16)
    Image.fromarray(rgb).save(tmp_path / "rgb.png", optimize=True)
    Image.fromarray(depth).save(tmp_path / "depth.png")
    np.testing.assert_array_equal(frames.read_rgb(str(tmp_path / "rgb.png")), rgb)
    np.testing.assert_allclose(frames.read_depth(str(tmp_path / "depth.png")), depth / 1000.0, rtol=1e-6)


def test_save_png_writes_16_bit_depth_that_reads_back(tmp_path):
    depth = np.array([[0, 1, 65535], [1000, 2, 30000]], np.uint16)
    save_png(str(tmp_path / "d.png"), depth)
    np.testing.assert_array_equal(frames.read_png(str(tmp_path / "d.png")), depth)
