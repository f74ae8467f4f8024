"""DAES exploration: schedule, greedy argmax, object-pixel sampling, ablation, fallback."""
import jax
import jax.numpy as jnp
import numpy as np

from vags_jax.rl import exploration
from vags_jax.config import Exploration

B, R, H, W = 512, 4, 8, 8
CFG = Exploration(height_threshold=0.01)
CFG_ALL = Exploration(daes=False, height_threshold=0.01)
OBJECT_PIXELS = [(1, 2), (5, 5), (6, 0)]


def _height_map():
    h = np.zeros((H, W), np.float32)
    h[0, 0] = 0.005  # below the threshold: not an object
    for r, c in OBJECT_PIXELS:
        h[r, c] = 0.03
    return jnp.broadcast_to(jnp.asarray(h), (B, H, W))


_select_grasp = jax.jit(exploration.select_grasp, static_argnums=4)
_select_pixel = jax.jit(exploration.select_pixel, static_argnums=4)


def test_epsilon_schedule():
    cfg = Exploration(eps_start=0.5, eps_end=0.1, eps_decay=0.9)
    np.testing.assert_allclose(exploration.epsilon(0, cfg), 0.5)
    np.testing.assert_allclose(exploration.epsilon(10, cfg), 0.5 * 0.9**10, rtol=1e-6)  # 0.1743
    np.testing.assert_allclose(exploration.epsilon(1000, cfg), 0.1)  # floored at eps_end
    steps = jnp.array([0, 1, 2, 100])
    np.testing.assert_allclose(exploration.epsilon(steps, cfg), [0.5, 0.45, 0.405, 0.1], rtol=1e-6)


def test_greedy_when_eps_zero():
    kq, kh, ks = jax.random.split(jax.random.key(0), 3)
    q = jax.random.normal(kq, (B, R, H, W))
    height = jax.random.uniform(kh, (B, H, W)) * 0.02
    action, explored = _select_grasp(ks, q, height, 0.0, CFG)
    assert action.shape == (B, 3) and action.dtype == jnp.int32
    assert not bool(explored.any())
    expected = np.stack(np.unravel_index(np.asarray(q).reshape(B, -1).argmax(-1), (R, H, W)), -1)
    np.testing.assert_array_equal(action, expected)


def test_daes_explores_only_object_pixels():
    q = jnp.zeros((B, R, H, W)).at[:, 0, 0, 0].set(10.0)  # greedy would be the empty (0, 0)
    action, explored = _select_grasp(jax.random.key(1), q, _height_map(), 1.0, CFG)
    assert bool(explored.all())
    action = np.asarray(action)
    chosen = {(r, c) for r, c in action[:, 1:]}
    assert chosen == set(OBJECT_PIXELS)  # every object pixel, and nothing else
    counts = np.bincount(action[:, 0], minlength=R)
    assert counts.min() > B / R / 2  # random rotations cover 0..R-1 roughly uniformly


def test_whole_workspace_ablation_picks_empty_pixels():
    q = jnp.zeros((B, R, H, W))
    action, _ = _select_grasp(jax.random.key(2), q, _height_map(), 1.0, CFG_ALL)
    pix = {(r, c) for r, c in np.asarray(action)[:, 1:]}
    assert len(pix - set(OBJECT_PIXELS)) > 40  # 512 draws over 64 cells hit nearly all


def test_empty_map_falls_back_to_whole_map():
    q = jnp.zeros((B, R, H, W))
    action, explored = _select_grasp(jax.random.key(3), q, jnp.zeros((B, H, W)), 1.0, CFG)
    assert bool(explored.all())
    a = np.asarray(action)
    assert a[:, 1:].min() >= 0 and a[:, 1].max() < H and a[:, 2].max() < W
    assert len({(r, c) for r, c in a[:, 1:]}) > 40


def test_per_world_epsilon():
    eps = jnp.tile(jnp.array([0.0, 1.0]), B // 2)
    q = jnp.zeros((B, R, H, W)).at[:, 0, 0, 0].set(10.0)
    action, explored = _select_grasp(jax.random.key(4), q, _height_map(), eps, CFG)
    np.testing.assert_array_equal(explored, np.tile([False, True], B // 2))
    a = np.asarray(action)
    np.testing.assert_array_equal(a[0::2], np.zeros((B // 2, 3)))  # greedy argmax (0, 0, 0)
    assert {(r, c) for r, c in a[1::2, 1:]} <= set(OBJECT_PIXELS)


def test_select_pixel_vanet():
    kq, ks = jax.random.split(jax.random.key(5))
    q = jax.random.normal(kq, (B, H, W))
    action, explored = _select_pixel(ks, q, _height_map(), 0.0, CFG)
    assert action.shape == (B, 2) and action.dtype == jnp.int32 and not bool(explored.any())
    expected = np.stack(np.unravel_index(np.asarray(q).reshape(B, -1).argmax(-1), (H, W)), -1)
    np.testing.assert_array_equal(action, expected)
    action, explored = _select_pixel(ks, q, _height_map(), 1.0, CFG)
    assert bool(explored.all())
    assert {(r, c) for r, c in np.asarray(action)} == set(OBJECT_PIXELS)
