"""impl "jax" and impl "warp" give the same grasp outcomes on the same scenes.

Runs wherever warp-lang is installed (MuJoCo Warp runs on the CPU too, slowly); skipped
otherwise.  Scenes come from tests/grasp_scenarios.py: cubes grasped correctly (succeed), empty
spots and long cuboids grasped along their length (fail).
"""
import jax
import numpy as np
import pytest

pytest.importorskip("warp", reason="impl 'warp' needs warp-lang (pip install -e '.[warp]')")

from vags_jax.sim.scene import build_scene  # noqa: E402
from vags_jax.sim.simulator import Simulator, check_overflow  # noqa: E402

from grasp_scenarios import scenarios, tiny_config  # noqa: E402

N_CUBE, N_EMPTY, N_LONG = 6, 2, 4


@pytest.fixture(scope="module")
def outcomes():
    out = {}
    for impl in ("jax", "warp"):
        cfg = tiny_config(**{"sim.impl": impl})
        sim = Simulator(cfg, build_scene(cfg))
        sc = scenarios(N_CUBE, N_EMPTY, N_LONG, sim.P, cfg, seed=1)
        state = sim.set_objects(sim.empty(sc["pos"].shape[0]), sc["pos"], sc["quat"], sc["active"])
        new_state, res = sim.grasp_at(state, sc["position"], sc["yaw"])
        jax.block_until_ready(res.success)
        out[impl] = (new_state, res)
    return out


def test_same_grasp_outcomes(outcomes):
    (_, rj), (_, rw) = outcomes["jax"], outcomes["warp"]
    np.testing.assert_array_equal(np.asarray(rj.success), np.asarray(rw.success))
    np.testing.assert_array_equal(np.asarray(rj.object), np.asarray(rw.object))
    expected = np.r_[np.ones(N_CUBE, bool), np.zeros(N_EMPTY + N_LONG, bool)]
    np.testing.assert_array_equal(np.asarray(rw.success), expected)
    # Finger gaps after the lift agree within 3 mm (same pads, same object).
    np.testing.assert_allclose(np.asarray(rj.gripper_gap), np.asarray(rw.gripper_gap), atol=0.003)


def test_warp_buffers_did_not_overflow(outcomes):
    st, _ = outcomes["warp"]
    check_overflow(st)  # raises with the worlds and the setting to change
    assert not np.asarray(st.error).any()


def test_gpu_preset_physics_keeps_the_scripted_outcomes():
    """The ``gpu`` preset's physics settings (6 ms step, solver cap 2, MuJoCo's primitive
    box-box test, its grasp phases) on MuJoCo Warp: correct cube grasps still succeed, empty
    spots and wrong-axis cuboid grasps still fail, and its step count is at least 2.4x smaller
    than the 2 ms default's."""
    from vags_jax.config import preset

    gpu = preset("gpu")  # all of the preset's physics and grasp phases, whatever they hold
    cfg = tiny_config(sim=gpu.sim, grasp=gpu.grasp)
    sim = Simulator(cfg, build_scene(cfg))
    default = Simulator(tiny_config(**{"sim.impl": "warp"}), build_scene(tiny_config()))
    assert sim.n_grasp_steps * 2.4 < default.n_grasp_steps
    sc = scenarios(N_CUBE, N_EMPTY, N_LONG, sim.P, cfg, seed=2)
    state = sim.set_objects(sim.empty(sc["pos"].shape[0]), sc["pos"], sc["quat"], sc["active"])
    new_state, res = sim.grasp_at(state, sc["position"], sc["yaw"])
    expected = np.r_[np.ones(N_CUBE, bool), np.zeros(N_EMPTY + N_LONG, bool)]
    np.testing.assert_array_equal(np.asarray(res.success), expected)
    check_overflow(new_state)
    assert not np.asarray(new_state.error).any()


def test_sleeping_objects_wake_when_teleported():
    """``sim.sleep``: a cube at rest falls asleep (MuJoCo Warp stops simulating it, and contacts
    between sleeping bodies are skipped); teleporting it into the air must wake its world, or it
    would hang where it was put."""
    from grasp_scenarios import CUBE

    cfg = tiny_config(**{"sim.impl": "warp", "sim.timestep": 0.005, "sim.iterations": 5, "sim.sleep": True})
    sim = Simulator(cfg, build_scene(cfg))
    sc = scenarios(2, 0, 0, sim.P, cfg, seed=2)
    # 0.3 s settles (60 steps each; the same settle program both times): the cube is asleep well
    # before (0.15 s was enough) and, teleported 12.5 cm up, lands after 0.16 s of free fall.
    state = sim.settle(sim.set_objects(sim.empty(2), sc["pos"], sc["quat"], sc["active"]), 0.3)
    cube_tree = sim.scene.mj_model.dof_treeid[sim.scene.object_dof_adr[CUBE]]
    assert (np.asarray(state.data._impl.tree_asleep)[:, cube_tree] >= 0).all()  # noqa: SLF001
    pos = np.asarray(sc["pos"]).copy()
    pos[:, CUBE, 2] = 0.15
    state = sim.settle(sim.set_objects(state, pos, sc["quat"], sc["active"]), 0.3)
    np.testing.assert_allclose(np.asarray(sim.object_positions(state))[:, CUBE, 2], 0.025, atol=0.002)
    assert not np.asarray(state.error).any()
