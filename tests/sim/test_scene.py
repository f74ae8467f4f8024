"""Scene assets and build_scene (MuJoCo C only: fast, no JAX compilation)."""
import mujoco
import numpy as np
import pytest

from vags_jax.config import Config, replace
from vags_jax.sim.scene import PALETTE, SHAPES, build_scene

VPG_SIZES = {  # name -> bounding box (m) of VPG's blocks (docs/baselines.md)
    "cuboid_long": (0.10, 0.05, 0.05),
    "cuboid_flat": (0.10, 0.05, 0.025),
    "cube": (0.05, 0.05, 0.05),
    "cuboid_tall": (0.05, 0.05, 0.10),
    "cube_half": (0.05, 0.05, 0.025),
    "arch": (0.093, 0.05, 0.049),
    "disc": (0.06, 0.06, 0.025),
    "cylinder": (0.045, 0.045, 0.05),
}


@pytest.fixture(scope="module")
def scene():
    return build_scene(Config())


def test_shape_catalogue_has_vpg_blocks_at_their_sizes():
    for name, size in VPG_SIZES.items():
        np.testing.assert_allclose(SHAPES[name].extents, size, atol=1e-3, err_msg=name)
    assert {"prism", "half_cylinder"} <= set(SHAPES)
    for name in ("arch", "disc", "cylinder", "prism", "half_cylinder"):
        assert SHAPES[name].kind == "mesh", "round / slanted shapes must be convex meshes"


def test_pool_indices_and_render_mask(scene):
    cfg, m = scene.cfg, scene.mj_model
    P = cfg.scene.pool_size
    assert scene.pool_size == P == 10  # default: one body per shape = the N = 10 slots
    two = build_scene(replace(cfg, **{"scene.copies_per_shape": 2}))
    assert two.pool_size == 20
    assert list(two.object_shape_index) == [i // 2 for i in range(20)]
    for arr in (scene.object_body_ids, scene.object_geom_ids, scene.object_qpos_adr,
                scene.object_dof_adr, scene.object_shape_index):
        assert arr.shape == (P,)
    assert scene.park_qpos.shape == (P, 7)
    # one geom per object body, belonging to it
    assert np.all(m.body_geomnum[scene.object_body_ids] == 1)
    assert np.all(m.geom_bodyid[scene.object_geom_ids] == scene.object_body_ids)
    assert [cfg.scene.shapes[k] for k in scene.object_shape_index] == list(scene.shape_names)
    # render mask: table, ground, objects; gripper geoms in group 3 and not rendered
    mask = scene.render_geom_mask
    assert mask.shape == (m.ngeom,) and mask.dtype == bool
    assert mask[scene.table_geom_id] and mask[scene.ground_geom_id]
    assert mask[scene.object_geom_ids].all()
    assert mask.sum() == P + 2
    gripper_body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "gripper")
    gripper_geoms = [g for g in range(m.ngeom) if m.body_rootid[m.geom_bodyid[g]] == gripper_body]
    assert len(gripper_geoms) == 3  # palm + 2 pads
    assert all(m.geom_group[g] == 3 and not mask[g] for g in gripper_geoms)
    assert scene.default_geom_rgb.shape == (m.ngeom, 3) and scene.default_geom_rgb.dtype == np.uint8
    assert scene.palette.shape == (10, 3) and scene.palette.dtype == np.uint8
    np.testing.assert_array_equal(scene.palette, PALETTE)


def test_solver_and_gripper_settings(scene):
    cfg, m = scene.cfg, scene.mj_model
    assert m.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC
    assert m.opt.impratio == pytest.approx(cfg.sim.impratio)
    assert m.opt.iterations == cfg.sim.iterations
    assert m.opt.timestep == pytest.approx(cfg.sim.timestep)
    act = scene.gripper_actuator_ids[4]
    np.testing.assert_allclose(m.actuator_forcerange[act], [-cfg.grasp.grip_force, cfg.grasp.grip_force])
    assert m.actuator_forcelimited[act]
    for pad in scene.pad_geom_ids:
        np.testing.assert_allclose(2 * m.geom_size[pad], [0.008, 0.024, 0.070])
        assert m.geom_friction[pad, 0] == pytest.approx(1.5)
    dofs = scene.gripper_dof_adr
    assert np.all(m.dof_armature[dofs] > 0), "every gripper slide / hinge needs armature"
    assert m.neq == 1 and m.eq_type[0] == mujoco.mjtEq.mjEQ_JOINT
    # full stroke of the pads
    assert m.actuator_ctrlrange[act, 1] * 2 == pytest.approx(cfg.grasp.finger_stroke)


def test_collision_options_reach_the_model():
    """Sim.cone / ccd_iterations / native_ccd / multi_ccd become MuJoCo options (the defaults
    leave MuJoCo's own: elliptic cones, 35 CCD iterations, native and multi-contact CCD on)."""
    from vags_jax import config as C

    base = build_scene(C.tiny()).mj_model
    assert base.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC and base.opt.ccd_iterations == 35
    assert base.opt.disableflags & (mujoco.mjtDisableBit.mjDSBL_NATIVECCD | mujoco.mjtDisableBit.mjDSBL_MULTICCD) == 0
    m = build_scene(C.replace(C.tiny(), **{"sim.cone": "pyramidal", "sim.ccd_iterations": 12,
                                           "sim.native_ccd": False, "sim.multi_ccd": False})).mj_model
    assert m.opt.cone == mujoco.mjtCone.mjCONE_PYRAMIDAL and m.opt.ccd_iterations == 12
    assert m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_NATIVECCD
    assert m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_MULTICCD


def test_unknown_shape_is_rejected():
    cfg = replace(Config(), **{"scene.shapes": ("cube", "teapot"), "scene.copies_per_shape": 5})
    with pytest.raises(ValueError, match="teapot"):
        build_scene(cfg)


def test_parked_pose_touches_nothing(scene):
    m = scene.mj_model
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, "park"))
    mujoco.mj_forward(m, d)
    assert d.ncon == 0
    assert np.all(np.abs(scene.park_qpos[:, 0]) > 1.5)
    np.testing.assert_allclose(d.xpos[scene.object_body_ids], scene.park_qpos[:, :3], atol=1e-6)
    gripper = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "gripper")
    np.testing.assert_allclose(d.xpos[gripper], scene.gripper_park_qpos[:3], atol=1e-6)


def test_every_shape_lands_on_the_table_in_mujoco_c():
    """Each shape dropped with a tilt comes to rest on the table top (meshes collide), with the
    default solver settings (Newton, 10 iterations, 20 line-search iterations)."""
    scene = build_scene(Config())
    m = scene.mj_model
    d = mujoco.MjData(m)
    key = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, "park")
    rng = np.random.default_rng(0)
    seen = set()
    for i, name in enumerate(scene.shape_names):
        if name in seen:
            continue
        seen.add(name)
        mujoco.mj_resetDataKeyframe(m, d, key)
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        a = scene.object_qpos_adr[i]
        d.qpos[a: a + 7] = [0.0, 0.0, 0.12, *q]
        for _ in range(500):
            mujoco.mj_step(m, d)
        z = d.qpos[a + 2]
        assert 0.0 < z < 0.07, f"{name} rests at z = {z}"
        assert np.linalg.norm(d.qvel[scene.object_dof_adr[i]: scene.object_dof_adr[i] + 3]) < 0.02, name


def test_mjx_contact_budget_is_scene_sized(scene):
    """MJX jax keeps only contacts_per_world contacts (deepest first) instead of ~1000."""
    from mujoco import mjx

    from vags_jax.config import object_pool
    from vags_jax.sim.scene import contacts_per_world, rows_per_contact

    C_legacy = object_pool("legacy", 10)

    cfg = scene.cfg
    # 10 objects: 4 on the table + ~16 with other objects each, 2 pads x 3 objects x 8, 8 pads
    # on the table -> 20 * 10 + 56 = 256 contacts per world.
    assert contacts_per_world(cfg) == 256
    # The ten fixed blocks (meshes: many candidate contact slots per pair) hit the budget ...
    legacy = build_scene(replace(cfg, **{"scene.shapes": C_legacy}))
    d = mjx.make_data(mjx.put_model(legacy.mj_model, impl="jax"), impl="jax")
    assert d._impl.ncon == contacts_per_world(cfg)
    assert d._impl.nefc <= 3 * contacts_per_world(cfg) + 16
    # ... the default boxes and capsules (primitive pairs) have fewer slots than the budget.
    d = mjx.make_data(mjx.put_model(scene.mj_model, impl="jax"), impl="jax")
    assert d._impl.ncon <= contacts_per_world(cfg)
    # Capsules roll with rolling friction (condim 6): up to 6 rows per contact; 3 without them.
    assert rows_per_contact(cfg) == 6
    assert rows_per_contact(replace(cfg, **{"scene.shapes": C_legacy})) == 3
    assert d._impl.nefc <= 6 * contacts_per_world(cfg) + 16
    small = replace(cfg, **{"sim.contacts_per_world": 64})
    assert contacts_per_world(small) == 64
