"""VPG's decision and learning signals (vags_jax/policies/vpg.py) on hand-made arrays, with
hand-computed expectations."""
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from vags_jax import config as C
from vags_jax.env import EnvState, VagsEnv
from vags_jax.policies import vpg
from vags_jax.rl import dqn

V = C.Vpg(change_cells=2, change_min=0.01, change_max=0.3)


def test_changed_cells_counts_only_changes_between_the_two_thresholds():
    before = np.zeros((2, 3, 3), np.float32)
    after = before.copy()
    after[0, 0, 0] = 0.05  # an object moved in: counts
    after[0, 0, 1] = 0.005  # sensor-size wobble, below 0.01 m: does not count
    after[0, 1, 1] = 0.35  # more than 0.3 m (a glitch): does not count
    before[0, 2, 2] = 0.04  # an object moved out: counts (|dh| = 0.04)
    after[0, 2, 0] = 0.011  # just above 0.01: counts
    after[1] = before[1] + 0.02  # world 1: all 9 cells rose by 2 cm
    n = np.asarray(vpg.changed_cells(jnp.asarray(before), jnp.asarray(after), V))
    assert n.tolist() == [3, 9]
    # More than change_cells = 2 changed cells is a change; exactly 2 is not.
    after[0, 2, 0] = 0.0
    assert np.asarray(vpg.scene_changed(jnp.asarray(before), jnp.asarray(after), V)).tolist() == [False, True]


def test_rewards_and_targets_on_hand_made_numbers():
    # Four worlds: a push that changed the scene, a push that changed nothing, a successful
    # grasp, a failed grasp that changed nothing; a fifth: a successful grasp ending the round.
    push = jnp.array([True, True, False, False, False])
    success = jnp.array([False, False, True, False, True])
    changed = jnp.array([True, False, False, False, True])
    over = jnp.array([False, False, False, False, True])
    r = vpg.reward(push, success, changed, V)
    np.testing.assert_allclose(r, [0.5, 0.0, 1.0, 0.0, 1.0])
    done = vpg.no_future(success, changed, over)
    assert np.asarray(done).tolist() == [False, True, False, True, True]
    # Next views' Q maps (b, 2R, H, W) with R = 2: the largest push value 0.3, grasp 0.8 in
    # every world, so max over both primitives is 0.8.
    q = np.zeros((5, 4, 2, 2), np.float32)
    q[:, 1, 0, 1] = 0.3
    q[:, 3, 1, 0] = 0.8
    y = dqn.td_target(r, done, jnp.asarray(q), gamma=0.5)
    np.testing.assert_allclose(y, [0.5 + 0.5 * 0.8, 0.0, 1.0 + 0.5 * 0.8, 0.0, 1.0], rtol=1e-6)


def _q():
    q = np.zeros((2, 4, 3, 3), np.float32)  # R = 2: channels 0, 1 push; 2, 3 grasp
    q[:, 1, 2, 0] = 0.9  # best push
    q[:, 3, 0, 2] = 0.4  # best grasp
    q[1, 0, 1, 1] = 1.5  # world 1: an even better push
    return jnp.asarray(q)


def test_greedy_is_the_argmax_over_both_primitives():
    assert np.asarray(vpg.greedy(_q())).tolist() == [[1, 2, 0], [0, 1, 1]]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_select_explores_the_primitive_never_the_pixel(seed):
    q = _q()
    a, explored = vpg.select(jax.random.PRNGKey(seed), q, 0.0)
    assert not np.asarray(explored).any()
    assert np.asarray(a).tolist() == [[1, 2, 0], [0, 1, 1]]
    a, explored = vpg.select(jax.random.PRNGKey(seed), jnp.broadcast_to(q[:1], (64,) + q.shape[1:]), 1.0)
    a = np.asarray(a)
    assert np.asarray(explored).all()
    # Each world takes the argmax within the primitive it drew: the best push or the best grasp.
    is_push = (a == [1, 2, 0]).all(1)
    is_grasp = (a == [3, 0, 2]).all(1)
    assert (is_push | is_grasp).all() and is_push.any() and is_grasp.any()


def test_attempt_of_maps_channels_to_pushes_and_grasps(tiny_cfg):
    cfg = tiny_cfg
    env = VagsEnv(cfg)
    H, R = cfg.workspace.heightmap_px, cfg.grasp.n_rotations
    height = jnp.zeros((2, H, H)).at[:, 5, 7].set(0.04)
    state = EnvState(sim=None, color=jnp.zeros((2, H, H, 3), jnp.uint8), height=height,
                     attempts=jnp.zeros(2, jnp.int32), successes=jnp.zeros(2, jnp.int32),
                     motions=jnp.zeros(2, jnp.int32), travel=jnp.zeros(2))
    a = vpg.attempt_of(env, state, jnp.array([[3, 5, 7], [R + 3, 5, 7]], jnp.int32))
    assert np.asarray(a.push).tolist() == [True, False]
    px = cfg.workspace.pixel_size
    xmin, _, ymin, _ = cfg.workspace.bounds
    np.testing.assert_allclose(a.position[:, 0], xmin + 7.5 * px, atol=1e-6)
    np.testing.assert_allclose(a.position[:, 1], ymin + 5.5 * px, atol=1e-6)
    # The push's fingertips go push.clearance above the surface; the grasp depth_below_surface under it.
    np.testing.assert_allclose(a.position[:, 2], [0.04 + cfg.push.clearance, 0.04 - cfg.grasp.depth_below_surface],
                               atol=1e-6)
    # Push direction and grasp closing axis of index 3 are both 3 * 2 pi / R; the push's 16
    # directions all differ, while grasps r and r + R / 2 are the same grasp.
    np.testing.assert_allclose(a.yaw, [3 * 2 * math.pi / R] * 2, rtol=1e-6)
    assert np.asarray(a.motions).tolist() == [1, 1]
