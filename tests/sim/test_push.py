"""VPG's push primitive (vags_jax/sim/push.py) on a lone cube, MJX impl "jax": one compiled
push call, one world per direction tested."""
import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from grasp_scenarios import CUBE, tiny_config, yaw_quat
from vags_jax.sim.push import push_batched
from vags_jax.sim.scene import build_scene
from vags_jax.sim.simulator import Simulator

# Directions 0, 90, 112.5 and 270 degrees (rotation indices 0, 4, 5, 12 of 16); the last world
# pushes a cube 4 cm from the workspace's edge outwards, off the table.
ANGLES = np.array([0.0, np.pi / 2, 5 * np.pi / 8, 3 * np.pi / 2])


@pytest.fixture(scope="module")
def pushed():
    cfg = tiny_config()
    sim = Simulator(cfg, build_scene(cfg))
    B, P = len(ANGLES) + 1, sim.P
    angles = np.concatenate([ANGLES, [0.0]])
    centre = np.zeros((B, 2))
    edge = cfg.workspace.bounds[1]  # x max of the workspace square
    centre[-1] = [edge - 0.04, 0.0]
    pos = np.zeros((B, P, 3))
    pos[:, CUBE, :2], pos[:, CUBE, 2] = centre, 0.025  # a 5 cm cube resting on the table
    quat = np.tile([1.0, 0, 0, 0], (B, P, 1))
    quat[:, CUBE] = np.asarray(yaw_quat(jnp.asarray(angles)))  # a face towards the push
    active = np.zeros((B, P), bool)
    active[:, CUBE] = True
    state = sim.set_objects(sim.empty(B), pos, quat, active)
    # Fingertips 1 cm above the table, the closed pads' leading face (8 mm ahead of the TCP)
    # 2 mm behind the cube's face: the cube should travel about the whole 10 cm.
    back = 0.025 + 0.008 + 0.002
    d = np.stack([np.cos(angles), np.sin(angles)], 1)
    position = np.concatenate([centre - back * d, np.full((B, 1), 0.01)], 1)
    start = np.tile(np.asarray(cfg.camera.global_position), (B, 1))
    f = jax.jit(functools.partial(push_batched, sim))
    s2, res = f(state, jnp.asarray(position, jnp.float32), jnp.asarray(angles, jnp.float32),
                jnp.asarray(start, jnp.float32))
    moved = np.asarray(sim.object_positions(s2))[:, CUBE] - pos[:, CUBE]
    return dict(cfg=cfg, moved=moved, d=d, active=np.asarray(s2.active)[:, CUBE], res=res, position=position,
                start=start, error=np.asarray(s2.error))


def test_push_moves_a_lone_block_about_10_cm_along_the_direction(pushed):
    n = len(ANGLES)
    d, moved = pushed["d"][:n], pushed["moved"][:n]
    along = (moved[:, :2] * d).sum(1)
    across = moved[:, 0] * -d[:, 1] + moved[:, 1] * d[:, 0]
    assert np.all((along > 0.08) & (along < 0.11)), along  # 10 cm, less the 2 mm gap and contact slack
    assert np.all(np.abs(across) < 0.01), across
    assert np.all(np.abs(moved[:, 2]) < 0.005)  # still resting on the table
    assert pushed["active"][:n].all() and not pushed["error"].any()


def test_block_pushed_off_the_table_is_lost(pushed):
    assert not pushed["active"][-1]  # deactivated: outside the workspace after the push


def test_push_travel(pushed):
    cfg, res = pushed["cfg"], pushed["res"]
    p0 = pushed["position"]
    pre = p0 + np.array([0, 0, 0.15])  # approach_height above the start point
    np.testing.assert_allclose(res.approach, np.linalg.norm(pre - pushed["start"], axis=1), rtol=1e-5)
    np.testing.assert_allclose(res.push, 0.10)
    np.testing.assert_allclose(res.descend, 0.15)
    end = p0[:, :2] + 0.10 * pushed["d"]
    np.testing.assert_allclose(np.asarray(res.end)[:, :2], end, atol=1e-6)
    np.testing.assert_allclose(np.asarray(res.end)[:, 2], 0.01 + cfg.push.lift_height, atol=1e-6)
