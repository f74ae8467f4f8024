"""Simulator: reset and the grasp primitive (impl "jax", CPU).

Built to be fast: one tiny scene (a cube and a long cuboid), one compiled reset (8 worlds)
and ONE compiled grasp call whose 56 worlds hold every grasp scenario at once.
"""
import mujoco
import numpy as np
import pytest
import jax
import jax.numpy as jnp

from vags_jax.config import replace
from vags_jax.sim.scene import FINGER_CLOSED_TARGET, build_scene
from vags_jax.sim.simulator import GraspResult, SimState, Simulator, check_overflow

from grasp_scenarios import CUBE, LONG, scenarios, tiny_config

N_CUBE, N_EMPTY, N_LONG = 40, 8, 8
EMPTY_TABLE = N_CUBE + N_EMPTY - 1  # an empty-spot world whose table holds no object


# Spelled out (they are also the defaults) because the hand-computed travel distances of
# test_grasp_travel_distances depend on them.
HAND = {"camera.global_position": (0.0, -0.25, 0.60), "grasp.approach_height": 0.15,
        "grasp.lift_height": 0.15, "grasp.min_height_above_table": 0.005,
        "grasp.depth_below_surface": 0.03}


@pytest.fixture(scope="module")
def cfg():
    return tiny_config(**HAND)


@pytest.fixture(scope="module")
def scene(cfg):
    return build_scene(cfg)


@pytest.fixture(scope="module")
def sim(cfg, scene):
    return Simulator(cfg, scene)


@pytest.fixture(scope="module")
def reset_state(sim):
    n = jnp.array([1, 2, 1, 2, 2, 1, 2, 2])
    return n, sim.reset(jax.random.PRNGKey(0), n)


@pytest.fixture(scope="module")
def grasp_batch(sim, cfg):
    """56 worlds: 40 isolated cubes grasped correctly, 8 empty spots, 8 long cuboids grasped
    with the closing axis along their 10 cm length.  One jitted grasp call."""
    sc = scenarios(N_CUBE, N_EMPTY, N_LONG, sim.P, cfg)
    # Two hand-chosen worlds for the travel test: world 0's cube at the workspace centre, and
    # the last empty-spot world (no object at all) grasping at (0.1, 0.1).
    sc["pos"][0, CUBE, :2] = sc["position"][0, :2] = (0.0, 0.0)
    sc["position"][EMPTY_TABLE, :2] = (0.1, 0.1)
    state = sim.set_objects(sim.empty(sc["pos"].shape[0]), sc["pos"], sc["quat"], sc["active"])
    new_state, res = sim.grasp_at(state, sc["position"], sc["yaw"])
    jax.block_until_ready(res.success)
    return dict(state=state, new_state=new_state, res=res, **sc)


# ----------------------------------------------------------------------------- grasping


def test_grasp_centre_of_cube_succeeds(grasp_batch):
    res = grasp_batch["res"]
    ok = np.asarray(res.success[:N_CUBE])
    print(f"cube grasp success {ok.sum()}/{N_CUBE}")
    assert ok.mean() >= 0.95, f"cube grasp success {ok.mean():.2%}"
    np.testing.assert_array_equal(np.asarray(res.object[:N_CUBE])[ok], CUBE)
    gap = np.asarray(res.gripper_gap[:N_CUBE])[ok]
    np.testing.assert_allclose(gap, 0.05, atol=0.008)  # fingers stopped by the 5 cm cube


def test_grasped_object_is_parked_and_gripper_too(grasp_batch, sim, scene):
    res, st = grasp_batch["res"], grasp_batch["new_state"]
    ok = np.asarray(res.success)
    active = np.asarray(st.active)
    assert not active[ok, CUBE].any(), "grasped cube must be removed from the table"
    pos = np.asarray(sim.object_positions(st))
    np.testing.assert_allclose(pos[ok, CUBE], np.broadcast_to(scene.park_qpos[CUBE, :3], pos[ok, CUBE].shape), atol=1e-6)
    gq = np.asarray(st.data.qpos)[:, scene.gripper_qpos_adr]
    np.testing.assert_allclose(gq[:, :3], np.broadcast_to(scene.gripper_park_qpos[:3], gq[:, :3].shape), atol=0.02)
    # poses are up to date for the renderer
    np.testing.assert_allclose(np.asarray(st.data.xpos)[ok][:, scene.object_body_ids[CUBE]],
                               np.broadcast_to(scene.park_qpos[CUBE, :3], (ok.sum(), 3)), atol=1e-6)
    assert not np.asarray(st.error).any() and not np.asarray(st.overflow).any()
    check_overflow(st)


def test_grasp_on_empty_spot_fails(grasp_batch):
    res, st = grasp_batch["res"], grasp_batch["new_state"]
    e = slice(N_CUBE, N_CUBE + N_EMPTY)
    assert not np.asarray(res.success[e]).any()
    np.testing.assert_array_equal(np.asarray(res.object[e]), -1)
    assert np.all(np.asarray(res.gripper_gap[e]) < 0.005)  # closed on nothing
    # the far-away cube is untouched and still on the table
    np.testing.assert_array_equal(np.asarray(st.active[e]), grasp_batch["active"][e])


def test_grasp_along_long_axis_of_cuboid_fails(grasp_batch):
    res, st = grasp_batch["res"], grasp_batch["new_state"]
    lg = slice(N_CUBE + N_EMPTY, None)
    assert not np.asarray(res.success[lg]).any()
    assert np.asarray(st.active[lg, LONG]).all()


def test_grasp_travel_distances(grasp_batch):
    """Commanded travel, hand-computed for two worlds.  The approach runs from the global
    capture position (0, -0.25, 0.60) to 15 cm above the grasp point:
      * world 0, cube (5 cm) at the centre: grasp point z = 0.05 - 0.03 = 0.02, pre-grasp
        (0, 0, 0.17), approach = |(0, 0.25, -0.43)| = sqrt(0.2474) = 0.497393 m;
      * world EMPTY_TABLE, nothing on the table, grasp at (0.1, 0.1): the grasp point
        (z = -0.03) is raised to the 5 mm floor, pre-grasp (0.1, 0.1, 0.155),
        approach = |(0.1, 0.35, -0.445)| = sqrt(0.330525) = 0.574913 m.
    The commanded descent is the whole 15 cm (the guarded descent simulates only its end) and
    the lift 15 cm, in every world."""
    res = grasp_batch["res"]
    approach = np.asarray(res.approach)
    np.testing.assert_allclose(approach[[0, EMPTY_TABLE]], [0.497393, 0.574913], rtol=1e-5)
    np.testing.assert_allclose(np.asarray(res.descend), 0.15, rtol=1e-5)
    np.testing.assert_allclose(np.asarray(res.lift), 0.15, rtol=1e-6)
    # Any approach is at least the vertical drop from the capture height to the pre-grasp pose.
    assert (approach >= 0.60 - (0.05 - 0.03 + 0.15) - 1e-6).all()
    assert isinstance(res, GraspResult) and res.success.shape == (approach.shape[0],)


def test_guarded_descent_starts_above_the_highest_object_within_reach(sim, scene, cfg):
    """descent_start, hand-computed: clearance above the highest bounding-box corner of an
    active object within reach, else above the grasp point, capped at approach_height."""
    h = float(scene.object_half_height[CUBE])  # upright cube: half its edge
    c, ah = cfg.grasp.descent_clearance, cfg.grasp.approach_height
    B, P = 5, sim.P
    pos = np.tile(np.array([0.4, 0.4, 0.3], np.float32), (B, P, 1))  # parked positions (inactive)
    quat = np.tile(np.array([1, 0, 0, 0], np.float32), (B, P, 1))
    active = np.zeros((B, P), bool)
    pos[0, CUBE] = [0.0, 0.0, h]  # upright cube under the gripper
    pos[1, CUBE] = [0.15, 0.0, h]  # upright cube out of reach (0.15 m > stroke / 2 + 2 cm + radius)
    pos[2, CUBE] = [0.0, 0.0, 0.1]  # cube tilted 45 deg about x, held at 10 cm
    quat[2, CUBE] = [np.cos(np.pi / 8), np.sin(np.pi / 8), 0, 0]
    pos[3, CUBE] = [0.0, 0.0, h]  # the same cube, but not active
    pos[4, CUBE] = [0.0, 0.0, 0.5]  # a cube far above: capped at approach_height
    active[[0, 1, 2, 4], CUBE] = True
    state = sim.set_objects(sim.empty(B), pos, quat, active)
    zg = np.array([2 * h - 0.03, 0.01, 0.02, 0.01, 0.01], np.float32)
    zs = np.asarray(sim.descent_start(state.data, state.active, jnp.zeros(B), jnp.zeros(B), jnp.asarray(zg)))
    expect = [2 * h + c, 0.01 + c, 0.1 + np.sqrt(2) * h + c, 0.01 + c, 0.01 + ah]
    np.testing.assert_allclose(zs, expect, atol=1e-5)


@pytest.mark.parametrize("hold", [0.25, 0.0])
def test_lift_schedule_holds_for_lift_hold_of_the_lift(scene, hold):
    """The lift fraction rises along a half cosine over (1 - lift_hold) of ``t_lift`` and then
    holds 1 until the grasp is judged; with no hold it reaches 1 at the last lift step."""
    cfg = replace(tiny_config(), **{"grasp.lift_hold": hold})
    sched = Simulator(cfg, scene).schedule
    g, dt = cfg.grasp, cfg.sim.timestep
    n_lift = int(round(g.t_lift / dt))
    lift = sched[-n_lift:, 1]
    assert (sched[:-n_lift, 1] == 0).all()
    n_move = int(round((1 - hold) * n_lift))
    assert (np.diff(lift[:n_move]) > 0).all() and lift[n_move - 2] < 1.0
    np.testing.assert_allclose(lift[n_move - 1:], 1.0, atol=1e-6)


def test_mujoco_c_runs_the_same_grasp(grasp_batch, sim, scene):
    """The scene compiles in MuJoCo C; the same scripted grasp (schedule of the simulator)
    lifts the cube there too, and the final pad gap agrees with MJX."""
    m = scene.mj_model
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, "park"))
    w = 0
    a = scene.object_qpos_adr[CUBE]
    d.qpos[a: a + 7] = np.concatenate([grasp_batch["pos"][w, CUBE], grasp_batch["quat"][w, CUBE]])
    x, y, zg = grasp_batch["position"][w]
    yaw = (grasp_batch["yaw"][w] + np.pi / 2) % np.pi - np.pi / 2
    st = grasp_batch["state"]
    zpre = float(sim.descent_start(st.data, st.active, *[jnp.asarray(grasp_batch["position"][:, i]) for i in range(3)])[w])
    fo = sim.finger_open
    d.qpos[scene.gripper_qpos_adr] = [x, y, zpre, yaw, fo, fo]
    for s in sim.schedule:
        z = zpre + (zg - zpre) * s[0] + sim.cfg.grasp.lift_height * s[1]
        d.ctrl[scene.gripper_actuator_ids] = [x, y, z, yaw, fo + (FINGER_CLOSED_TARGET - fo) * s[2]]
        mujoco.mj_step(m, d)
    assert d.qpos[a + 2] > 0.025 + sim.cfg.grasp.success_lift
    gap_c = d.qpos[scene.gripper_qpos_adr[4]] + d.qpos[scene.gripper_qpos_adr[5]]
    assert bool(grasp_batch["res"].success[w])
    assert abs(gap_c - float(grasp_batch["res"].gripper_gap[w])) < 0.002


# ----------------------------------------------------------------------------- reset


def test_grasp_or_reset_grasps_in_some_worlds_and_resets_the_others(grasp_batch, sim, scene, cfg):
    """The training loop's step: every 4th world gets a new scene that settles while the
    others grasp; the grasping worlds' outcomes are those of a plain grasp.  On 16 of the
    fixture's worlds (8 cubes, 4 empty spots, 4 long cuboids; 4 of them reset), not all 56:
    half of this test's time was running the step, which grows with the worlds; the check is
    the same per world."""
    B0 = grasp_batch["pos"].shape[0]
    pick = np.r_[0:8, N_CUBE:N_CUBE + 4, N_CUBE + N_EMPTY:N_CUBE + N_EMPTY + 4]
    B = pick.size
    state = jax.tree.map(lambda x: x[pick] if np.ndim(x) and np.shape(x)[0] == B0 else x, grasp_batch["state"])
    reset = np.arange(B) % 4 == 0
    n_new = np.where(reset, 2, 0).astype(np.int32)
    start = np.broadcast_to(np.asarray(cfg.camera.global_position, np.float32), (B, 3))
    keys = jax.random.split(jax.random.PRNGKey(5), B)
    st, res = jax.jit(sim.grasp_or_reset_batched)(
        state, jnp.asarray(grasp_batch["position"][pick], jnp.float32),
        jnp.asarray(grasp_batch["yaw"][pick], jnp.float32), jnp.asarray(start), jnp.asarray(reset), keys,
        jnp.asarray(n_new))
    ok, ref = np.asarray(res.success), np.asarray(grasp_batch["res"].success)[pick]
    assert ref[~reset].any() and not ref[~reset].all(), "the check needs grasps that succeed and grasps that fail"
    np.testing.assert_array_equal(ok[~reset], ref[~reset])
    np.testing.assert_array_equal(np.asarray(st.active)[~reset],
                                  np.asarray(grasp_batch["new_state"].active)[pick][~reset])
    # reset worlds: no grasp, a fresh 2-object scene at rest on the table
    assert not ok[reset].any() and (np.asarray(res.object)[reset] == -1).all()
    for f in (res.approach, res.descend, res.lift, res.gripper_gap):
        np.testing.assert_array_equal(np.asarray(f)[reset], 0.0)
    active = np.asarray(st.active)
    np.testing.assert_array_equal(active[reset].sum(1), 2)
    np.testing.assert_array_equal(np.asarray(st.n_objects)[reset], 2)
    pos = np.asarray(sim.object_positions(st))
    assert np.all((pos[reset][active[reset]][:, 2] > 0.0) & (pos[reset][active[reset]][:, 2] < 0.1))
    qvel = np.asarray(st.data.qvel)
    for b in np.flatnonzero(reset):
        for i in np.flatnonzero(active[b]):
            v = qvel[b, scene.object_dof_adr[i]: scene.object_dof_adr[i] + 3]
            assert np.abs(v).max() < 0.05, (b, i, v)
    assert not np.asarray(st.error).any() and not np.asarray(st.overflow).any()


def test_reset_puts_n_objects_on_the_table_at_rest(reset_state, sim, scene, cfg):
    n, st = reset_state
    assert isinstance(st, SimState)
    B = n.shape[0]
    active = np.asarray(st.active)
    assert active.shape == (B, sim.P)
    np.testing.assert_array_equal(active.sum(1), np.asarray(n))
    np.testing.assert_array_equal(np.asarray(st.n_objects), np.asarray(n))
    pos = np.asarray(sim.object_positions(st))
    xmin, xmax, ymin, ymax = cfg.workspace.bounds
    on = pos[active]
    assert np.all((on[:, 0] > xmin) & (on[:, 0] < xmax) & (on[:, 1] > ymin) & (on[:, 1] < ymax))
    assert np.all((on[:, 2] > 0.0) & (on[:, 2] < 0.15)), on[:, 2]
    vel = np.asarray(sim.object_velocities(st))
    assert vel.shape == (B, sim.P, 6)
    np.testing.assert_array_equal(vel, np.asarray(st.data.qvel)[:, scene.object_dof_adr[:, None] + np.arange(6)])
    v = vel[active]
    assert np.abs(v[:, :3]).max() < 0.05 and np.abs(v[:, 3:]).max() < 1.0, v
    parked = pos[~active]
    idx = np.nonzero(~active)[1]
    np.testing.assert_allclose(parked, scene.park_qpos[idx, :3], atol=1e-6)
    assert not np.asarray(st.error).any() and not np.asarray(st.overflow).any()
    # colours: objects from the palette, distinct within a world; table / ground fixed
    rgb = np.asarray(st.geom_rgb)
    assert rgb.shape == (B, scene.mj_model.ngeom, 3) and rgb.dtype == np.uint8
    pal = {tuple(c) for c in scene.palette}
    for b in range(B):
        cols = [tuple(rgb[b, scene.object_geom_ids[i]]) for i in np.flatnonzero(active[b])]
        assert set(cols) <= pal and len(set(cols)) == len(cols)
    np.testing.assert_array_equal(rgb[:, scene.table_geom_id], np.broadcast_to(scene.default_geom_rgb[scene.table_geom_id], (B, 3)))


def test_reset_draws_random_shapes(reset_state):
    n, st = reset_state
    active = np.asarray(st.active)
    single = active[np.asarray(n) == 1]
    assert single[:, CUBE].any() and single[:, LONG].any() or len(single) < 3


@pytest.mark.parametrize("bad", [[0, 1], [1, 3], [-1], [1.5, 1.0], []])
def test_reset_rejects_bad_object_counts(sim, bad):
    with pytest.raises(ValueError, match=r"1\.\.2"):
        sim.reset(jax.random.PRNGKey(0), np.array(bad))


def test_check_overflow_raises_and_warns(reset_state):
    _, st = reset_state
    check_overflow(st)  # clean state: silent
    bad = st.replace(overflow=st.overflow.at[3].set(True))
    with pytest.raises(RuntimeError, match="naconmax"):
        check_overflow(bad)
    with pytest.warns(RuntimeWarning, match="worlds"):
        check_overflow(st.replace(error=st.error.at[0].set(True)), warn=True)


def test_warp_without_warp_lang_is_a_clear_error(cfg, scene):
    try:
        import warp  # noqa: F401
        pytest.skip("warp-lang is installed")
    except ImportError:
        pass
    with pytest.raises(ImportError, match="warp-lang"):
        Simulator(replace(cfg, **{"sim.impl": "warp"}), scene)


def test_long_time_step_with_impl_jax_warns(cfg, scene):
    """MJX jax pried the pads open at 4 ms: a step above 2 ms with impl "jax" is not silent."""
    with pytest.warns(UserWarning, match="sim.timestep"):
        Simulator(replace(cfg, **{"sim.timestep": 0.004}), scene)


def test_reset_and_grasp_trace_inside_an_outer_jit(sim):
    """Usable in a jitted training loop with traced n_objects (shape-only, nothing compiled)."""
    B = 3

    def loop(key, n, position, yaw):
        st = sim.reset(key, n)
        return sim.grasp_at(st, position, yaw)

    st, res = jax.eval_shape(loop, jax.random.PRNGKey(0), jnp.array([1, 2, 1]),
                             jnp.zeros((B, 3)), jnp.zeros((B,)))
    assert st.active.shape == (B, sim.P) and st.geom_rgb.shape[0] == B
    assert res.success.shape == (B,) and res.object.dtype == jnp.int32
