"""The paper's scene protocol: objects of drawn shape, size and colour, piled; the held-out set;
the sensor model; the oblique global pose.  CPU, tiny sizes (MuJoCo C for mass properties)."""
import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest

from vags_jax.perception import camera, render
from vags_jax import config as C
from vags_jax.config import DepthNoise, OBJECT_SETS, object_pool, replace
from vags_jax.sim.scene import KIND_BOX, KIND_CAPSULE, KIND_SPHERE, SHAPES, build_scene, size_ranges, sized_body_physics

PILE_WORLDS = 12


@pytest.fixture(scope="module")
def clutter_env(tiny_cfg):
    """Tiny training-set scenes (2 boxes + 1 capsule, piled), MJX jax: the conftest's tiny_cfg,
    whose reset of 2 worlds the stages' environment compiles too (one program for the suite)."""
    from vags_jax.env import VagsEnv

    return VagsEnv(tiny_cfg)


def _reset_in_pairs(env, key):
    """PILE_WORLDS worlds of max_objects objects, reset 2 at a time (the 2-world reset program
    that tiny_cfg's stages compile; worlds are independent draws either way) and joined."""
    n = np.full(2, env.cfg.scene.max_objects, np.int32)
    parts = [env.reset(jax.random.fold_in(key, i), n) for i in range(PILE_WORLDS // 2)]
    assert all(np.ndim(x) and np.shape(x)[0] == 2 for x in jax.tree.leaves(parts[0]))  # every leaf per world
    return jax.tree.map(lambda *xs: jnp.concatenate(xs), *parts)


@pytest.fixture(scope="module")
def two_resets(clutter_env):
    return _reset_in_pairs(clutter_env, jax.random.PRNGKey(1)), _reset_in_pairs(clutter_env, jax.random.PRNGKey(2))


def test_sizes_and_colours_vary_across_worlds_and_resets_within_ranges(clutter_env, two_resets):
    env, (a, b) = clutter_env, two_resets
    sc = env.scene
    lo, hi = sc.object_size_lo, sc.object_size_hi
    for s in (a, b):
        size = np.asarray(s.sim.obj_size)  # (B, P, 3)
        assert np.all(size >= lo - 1e-7) and np.all(size <= hi + 1e-7)
    sa, sb = np.asarray(a.sim.obj_size), np.asarray(b.sim.obj_size)
    sized = sc.object_kind != 0
    assert sized.any()
    # Across worlds (one reset) and across resets (same world), every sized body's size differs.
    assert np.all(np.std(sa[:, sized, 0], axis=0) > 1e-3)
    assert np.all(np.abs(sa[:, sized, 0] - sb[:, sized, 0]).max(axis=0) > 1e-3)
    # Box sides are drawn independently: proportions vary (not one scaled cube).
    box = sc.object_kind == KIND_BOX
    ratio = sa[:, box, 0] / sa[:, box, 2]
    assert ratio.max() / ratio.min() > 1.5
    cfg = env.cfg.scene
    assert np.all(2 * sa[:, box] >= cfg.box_side[0] - 1e-6) and np.all(2 * sa[:, box] <= cfg.box_side[1] + 1e-6)
    # Colours: palette colours scaled by 1 +- jitter, different per world and per reset.
    ids = sc.object_geom_ids
    ca, cb = np.asarray(a.sim.geom_rgb)[:, ids].astype(int), np.asarray(b.sim.geom_rgb)[:, ids].astype(int)
    assert len({tuple(c) for c in ca.reshape(-1, 3)}) > PILE_WORLDS
    assert (ca != cb).any(axis=-1).mean() > 0.8
    pal = sc.palette.astype(float)
    j = cfg.colour_jitter
    ratios = ca[..., None, :] / np.maximum(pal[None, None], 1)  # (B, P, 10, 3)
    near = np.all((ratios >= 1 - j - 0.02) & (ratios <= 1 + j + 0.02), axis=-1).any(axis=-1)
    assert near.all(), "every object colour is a palette colour within the jitter"


def test_a_pile_has_an_object_resting_on_another_in_most_resets(clutter_env, two_resets):
    """Three objects dropped onto a small region: in most worlds one rests on or leans against
    another (its bottom above the table, or tilted out of every pose it could rest in alone)."""
    env = clutter_env
    piled, on_top = [], []
    for s in two_resets:
        piled.extend(np.asarray(env.sim.piled(s.sim)).any(axis=1))
        on_top.extend(((np.asarray(env.sim.object_bottoms(s.sim)) > 0.005) & np.asarray(s.sim.active)).any(axis=1))
        assert not np.asarray(s.sim.error).any() and not np.asarray(s.sim.overflow).any()
    assert np.mean(piled) > 0.5, f"worlds with an object on / against another: {np.mean(piled):.2f}"
    assert np.mean(on_top) > 0.15, f"worlds with an object on top of another: {np.mean(on_top):.2f}"


def test_scatter_placement_rarely_stacks(clutter_env):
    from vags_jax.env import VagsEnv

    cfg = replace(clutter_env.cfg, **{"scene.placement": "scatter"})
    env = VagsEnv(cfg)
    sim = env.sim.reset(jax.random.PRNGKey(1), np.full(PILE_WORLDS, 3, np.int32))  # physics only: no render
    bottom = np.asarray(env.sim.object_bottoms(sim))
    stacked = ((bottom > 0.005) & np.asarray(sim.active)).any(axis=1)
    assert stacked.mean() < 0.25
    assert np.asarray(env.sim.piled(sim)).any(axis=1).mean() < 0.5


def test_unseen_set_shares_no_shape_or_size_range_with_training():
    cfg = C.Config()
    train = {(n, _ranges_key(n, cfg)) for n in OBJECT_SETS["train"]}
    unseen = {(n, _ranges_key(n, cfg)) for n in OBJECT_SETS["unseen"]}
    assert not train & unseen
    assert not {n for n, _ in train} & {n for n, _ in unseen}
    kinds_train = {SHAPES[n].kind for n in OBJECT_SETS["train"]}
    # The unseen round shapes are other kinds (meshes, spheres), not capsules or boxes.
    assert not {SHAPES[n].kind for n in OBJECT_SETS["unseen"]} & kinds_train
    assert object_pool("unseen", 6) == OBJECT_SETS["unseen"]
    assert object_pool("train", 10).count("box") == 6


def _ranges_key(name, cfg):
    lo, hi = size_ranges(SHAPES[name], cfg.scene)
    return tuple(np.round(lo, 6)) + tuple(np.round(hi, 6))


def test_unseen_scene_builds_and_default_pool_is_the_training_set():
    cfg = C.Config()
    assert cfg.scene.shapes == object_pool("train", 10)
    sc = build_scene(replace(cfg, **{"scene.shapes": object_pool("unseen", 10)}))
    assert (sc.object_kind == KIND_SPHERE).sum() == 1  # 10 slots cycle the six unseen shapes
    assert sc.pool_size == 10


@pytest.mark.parametrize("field,value,words", [
    ("scene.box_side", (0.06, 0.03), "min > max"),
    ("scene.box_side", (-0.02, 0.05), "positive"),
    ("scene.capsule_radius", (0.03, 0.01), "min > max"),
    ("scene.capsule_length", (0.01, -0.01), "min > max"),
    ("scene.sphere_radius", (-0.01, 0.02), "positive"),
    ("scene.box_side", (0.02, 0.2), "gripper"),
    ("scene.box_side", (0.02,), "2 items"),
    ("scene.placement", "heap", "placement"),
    ("scene.pile_radius", -0.1, "pile_radius"),
    ("scene.colour_jitter", 0.9, "colour_jitter"),
    ("camera.noise.edge_dropout", 1.5, "probability"),
    ("camera.noise.sigma_base", -0.001, "sigma_base"),
    ("camera.noise.edge_width", 2.5, "edge_width"),
])
def test_bad_scene_and_sensor_values_are_clear_errors(field, value, words):
    with pytest.raises(ValueError, match=words):
        replace(C.Config(), **{field: value})


def _compiled_body(kind, size, density=500.0):
    geom = {KIND_BOX: "box", KIND_CAPSULE: "capsule", KIND_SPHERE: "sphere"}[kind]
    xml = (f'<mujoco><worldbody><body><freejoint/><geom type="{geom}" density="{density}" '
           f'size="{" ".join(str(v) for v in size if v > 0)}"/></body></worldbody></mujoco>')
    return mujoco.MjModel.from_xml_string(xml)


@pytest.mark.parametrize("kind,size", [
    (KIND_BOX, (0.02, 0.013, 0.035)), (KIND_BOX, (0.04, 0.04, 0.0125)),
    (KIND_CAPSULE, (0.015, 0.03, 0.0)), (KIND_CAPSULE, (0.03, 0.01, 0.0)), (KIND_SPHERE, (0.025, 0.0, 0.0)),
])
def test_drawn_mass_properties_match_mujoco_compiled_bodies(kind, size):
    m = _compiled_body(kind, size)
    phys = sized_body_physics(jnp.array([kind]), jnp.array([size], jnp.float32), 500.0)
    np.testing.assert_allclose(phys["mass"][0], m.body_mass[1], rtol=1e-5)
    np.testing.assert_allclose(np.sort(phys["inertia"][0]), np.sort(m.body_inertia[1]), rtol=1e-4)
    np.testing.assert_allclose(phys["invweight"][0], m.body_invweight0[1], rtol=1e-4)
    np.testing.assert_allclose(phys["rbound"][0], m.geom_rbound[0], rtol=1e-5)
    np.testing.assert_allclose(phys["aabb_half"][0], m.geom_aabb[0, 3:], rtol=1e-5)
    np.testing.assert_allclose(np.repeat(phys["invweight"][0], 3), m.dof_invweight0, rtol=1e-4)


def test_global_pose_sees_the_whole_workspace_obliquely():
    cam, ws = C.Camera(), C.Workspace()
    pose = camera.global_pose(cam)
    xmin, xmax, ymin, ymax = ws.bounds
    pts = np.array([[x, y, z] for x in (xmin, xmax) for y in (ymin, ymax) for z in (0.0, 0.12)], np.float32)
    uv, z = camera.project(jnp.asarray(pts), pose, cam)
    uv = np.asarray(uv)
    assert np.all(np.asarray(z) > 0)
    assert np.all((uv[:, 0] >= 0) & (uv[:, 0] < cam.width) & (uv[:, 1] >= 0) & (uv[:, 1] < cam.height))
    axis = np.asarray(pose)[:3, 2]  # optical axis in the world
    tilt = np.degrees(np.arccos(-axis[2]))
    assert 20 < tilt < 60, "not looking straight down at the workspace centre"


# ----------------------------------------------------------------------------- sensor model

def _plane_depth(h=48, w=64, tilt_deg=0.0, z0=0.6, fx=60.0):
    """Depth image of a plane seen by a pinhole camera, the plane tilted about the camera x axis."""
    v = (np.arange(h)[:, None] - h / 2) / fx
    t = np.tan(np.radians(tilt_deg))
    depth = z0 / (1.0 - t * v) * np.ones((1, w))  # plane z = z0 + t * y
    n = np.array([0.0, -np.sin(np.radians(tilt_deg)), np.cos(np.radians(tilt_deg))])
    rays = np.stack([(np.arange(w)[None, :] - w / 2) / fx * np.ones((h, 1)), v * np.ones((1, w)), np.ones((h, w))], -1)
    cos = np.abs(rays @ n) / np.linalg.norm(rays, axis=-1)
    return depth.astype(np.float32), cos.astype(np.float32)


def test_sensor_model_leaves_no_holes_on_a_flat_table_seen_head_on():
    depth, cos = _plane_depth(tilt_deg=0.0)
    out = np.asarray(render.add_depth_noise(jax.random.PRNGKey(0), jnp.asarray(depth), jnp.asarray(cos), DepthNoise()))
    assert (out > 0).all()
    assert 0.0003 < np.std(out - depth) < 0.004  # millimetres of noise at 0.6 m


def test_sensor_model_drops_steep_faces():
    depth, cos = _plane_depth(tilt_deg=80.0, z0=0.3)
    valid = depth > 0
    out = np.asarray(render.add_depth_noise(jax.random.PRNGKey(0), jnp.asarray(np.where(valid, depth, 0)),
                                            jnp.asarray(cos), DepthNoise()))
    steep = valid & (cos < np.cos(np.radians(75)))
    assert steep.sum() > 100
    assert (out[steep] == 0).all()


def test_sensor_model_drops_edge_pixels_and_quantises():
    depth = np.full((32, 32), 0.6, np.float32)
    depth[10:20, 10:20] = 0.55  # a 5 cm step: an object's edge
    cos = np.ones_like(depth)
    cfg = DepthNoise(sigma_base=0.0, sigma_quadratic=0.0, edge_dropout=1.0)
    out = np.asarray(render.add_depth_noise(jax.random.PRNGKey(0), jnp.asarray(depth), jnp.asarray(cos), cfg, fx=600.0))
    edge = np.asarray(render.depth_edges(jnp.asarray(depth), 0.01, 1))
    assert edge.sum() == 36 + 40  # both sides of the square's boundary: its border ring, the ring outside
    assert (out[edge] == 0).all() and (out[~edge] > 0).all()
    # Disparity fb / z rounded to 1/8 px: depth lands on the quantisation grid, within a step.
    fb = 600.0 * cfg.baseline
    disp = fb / out[~edge]
    np.testing.assert_allclose(disp * 8, np.round(disp * 8), atol=1e-3)
    step = 0.6**2 * cfg.disparity_step / fb
    assert np.abs(out[~edge] - depth[~edge]).max() <= step / 2 + 1e-6
    off = np.asarray(render.add_depth_noise(jax.random.PRNGKey(0), jnp.asarray(depth), jnp.asarray(cos),
                                            DepthNoise(enabled=False)))
    np.testing.assert_array_equal(off, depth)


def test_pile_scenes_started_in_the_training_step_drop_while_others_grasp(clutter_env, two_resets):
    """grasp_or_reset_batched: the reset worlds' pile objects are dropped one after another
    inside the grasp loop and are all on the table, at rest, at its end."""
    env = clutter_env
    sim, state = env.sim, two_resets[0].sim
    B = state.n_worlds
    reset = np.arange(B) % 2 == 0
    n_new = np.where(reset, 3, 0).astype(np.int32)
    pos = np.asarray(sim.object_positions(state))
    target = pos[np.arange(B), np.asarray(state.active).argmax(1)]  # some object's centre
    start = np.broadcast_to(np.asarray(env.cfg.camera.global_position, np.float32), (B, 3))
    st, res = jax.jit(sim.grasp_or_reset_batched)(
        state, jnp.asarray(target), jnp.zeros(B), jnp.asarray(start), jnp.asarray(reset),
        jax.random.split(jax.random.PRNGKey(9), B), jnp.asarray(n_new))
    active = np.asarray(st.active)
    assert (active[reset].sum(1) >= 2).all() and active[reset].sum() >= 0.9 * 3 * reset.sum()
    assert not np.asarray(res.success)[reset].any()
    speed = np.linalg.norm(np.asarray(sim.object_velocities(st))[reset][active[reset]][:, :3], axis=-1)
    assert np.mean(speed < 0.05) >= 0.8, speed  # most at rest (a capsule may still roll)
    bottom = np.asarray(sim.object_bottoms(st))[reset][active[reset]]
    assert bottom.min() > -0.005 and bottom.max() < 0.15  # soft contacts: a few mm into the table under a pile
    assert not np.asarray(st.error).any() and not np.asarray(st.overflow).any()
