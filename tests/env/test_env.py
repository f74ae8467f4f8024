"""VagsEnv: input validation of the public API, and world-chunked rendering."""
import jax
import numpy as np
import pytest

from vags_jax import config as C
from vags_jax.env import VagsEnv, where_worlds


# Exact-rendering checks below compare images: the sensor model (on by default) is off here;
# test_observe_with_depth_noise checks it.  The scenes come from the tiny test config's reset (``noisy``).
CLEAN = {"camera.noise.enabled": False}


@pytest.fixture(scope="module")
def env(tiny_cfg):
    return VagsEnv(C.replace(tiny_cfg, **CLEAN))


@pytest.fixture(scope="module")
def noisy(tiny_cfg):
    """The tiny test config's environment (the sensor model on): its reset of 2 worlds is the suite's."""
    return VagsEnv(tiny_cfg)


@pytest.fixture(scope="module")
def reset_state(noisy):
    return noisy.reset(jax.random.PRNGKey(1), np.array([1, 2]))


@pytest.fixture(scope="module")
def state(env, reset_state):
    """The reset's scenes seen without the sensor model (for the exact-rendering checks)."""
    color, height = jax.jit(env.observe_global)(reset_state.sim)
    return reset_state.replace(color=color, height=height)


def test_reset_puts_objects_in_the_heightmap(env, noisy, reset_state):
    """The reset's own heightmaps are the observation of its settled scenes, with its key."""
    state = reset_state
    assert np.asarray(env.n_remaining(state)).tolist() == [1, 2]
    _, k_obs = jax.random.split(jax.random.PRNGKey(1))
    _, height = jax.jit(noisy.observe_global)(state.sim, k_obs)
    np.testing.assert_allclose(np.asarray(height), np.asarray(state.height), atol=1e-5, rtol=0)
    h = np.asarray(state.height)
    assert h.shape == (2, 32, 32) and (h.max(axis=(1, 2)) > 0.02).all()
    assert state.color.dtype == np.uint8 and state.color.shape == (2, 32, 32, 3)


@pytest.mark.parametrize("n", [[0, 1], [1, 4], [1.5, 1], [[1, 1]]])
def test_reset_rejects_bad_object_counts(env, n):
    with pytest.raises(ValueError, match=r"1\.\.3"):
        env.reset(jax.random.PRNGKey(0), np.array(n))


@pytest.mark.parametrize("pixel, rotation, match", [
    ([[0, 0], [0, 32]], [0, 0], r"0\.\.31"),
    ([[-1, 0], [0, 0]], [0, 0], r"0\.\.31"),
    ([[0, 0]], [0, 0], r"\(2, 2\)"),
    ([[0.5, 0], [0, 0]], [0, 0], "integer"),
    ([[0, 0], [0, 0]], [0, 16], r"0\.\.15 \(16 rotations of 22\.5 deg\)"),
    ([[0, 0], [0, 0]], [-1, 0], r"0\.\.15"),
    ([[0, 0], [0, 0]], [0], r"\(2,\)"),
])
def test_grasp_rejects_bad_actions(env, state, pixel, rotation, match):
    with pytest.raises(ValueError, match=match):
        env.grasp(state, np.array(pixel), np.array(rotation))


def test_grasp_at_rejects_bad_shapes(env, state):
    with pytest.raises(ValueError, match=r"\(2, 3\)"):
        env.grasp_at(state, np.zeros((2, 2)), np.zeros(2))


def test_rendering_in_world_chunks_is_identical(tiny_cfg, env, state):
    chunked = VagsEnv(C.replace(tiny_cfg, **{"camera.render_batch": 1, **CLEAN}))
    color, height = jax.jit(chunked.observe_global)(state.sim)
    ref_color, ref_height = jax.jit(env.observe_global)(state.sim)
    # Per-world object sizes enter the ray tests; batches of 1 and 2 fuse differently in XLA,
    # so heights may differ in the last float bits (4e-6 m seen), colours not at all.
    np.testing.assert_allclose(np.asarray(height), np.asarray(ref_height), atol=1e-5, rtol=0)
    np.testing.assert_array_equal(np.asarray(color), np.asarray(ref_color))


def test_where_worlds_keeps_shared_leaves():
    mask = np.array([True, False, True])
    a = {"w": np.ones((3, 2)), "shared": np.full((5,), 7.0), "empty": np.zeros((0,))}
    b = {"w": np.zeros((3, 2)), "shared": np.full((5,), 1.0), "empty": np.zeros((0,))}
    out = where_worlds(mask, a, b)
    np.testing.assert_array_equal(np.asarray(out["w"])[:, 0], [1.0, 0.0, 1.0])
    np.testing.assert_array_equal(np.asarray(out["shared"]), b["shared"])


def test_observe_matches_colouring_the_whole_image(tiny_cfg, env, state):
    """observe colours only each cell's source pixel; the result is that of colouring the
    whole image (`render.render_full`) and taking the heightmaps of it."""
    from vags_jax.perception import heightmap, render

    cfg = env.cfg
    sim = state.sim
    pose = jax.numpy.broadcast_to(jax.numpy.asarray(env.global_pose), (2, 4, 4))
    geometry = env.geometry(2)

    @jax.jit
    def whole_image(xpos, xmat, rgb, pose, size):
        out = render.render_full(geometry, xpos, xmat, rgb, pose, cfg.camera, geom_size=size)
        return heightmap.heightmaps(out.depth, out.rgb, pose, cfg.camera, cfg.workspace)

    ref_color, ref_height = whole_image(sim.data.geom_xpos, sim.data.geom_xmat, sim.geom_rgb, pose,
                                        env.sim.geom_size(sim))
    color, height = jax.jit(env.observe)(sim, pose)
    np.testing.assert_array_equal(np.asarray(height), np.asarray(ref_height))
    np.testing.assert_array_equal(np.asarray(color), np.asarray(ref_color))
    assert np.asarray(ref_color).any(axis=-1).mean() > 0.3  # the comparison is not of black images


def test_observe_with_depth_noise(noisy, state):
    """camera.noise: observe needs a key, and the noisy heightmaps stay close to the clean ones."""
    assert noisy.cfg.camera.noise.enabled
    with pytest.raises(ValueError, match="PRNG key"):
        noisy.observe_global(state.sim)
    color, height = jax.jit(noisy.observe_global)(state.sim, jax.random.PRNGKey(5))
    h, ref = np.asarray(height), np.asarray(state.height)
    assert not np.array_equal(h, ref)
    both = np.asarray(color).any(axis=-1) & np.asarray(state.color).any(axis=-1)  # seen in both
    assert both.mean() > 0.5 and np.median(np.abs(h - ref)[both]) < 0.003
    obj = both & (ref > 0.02)  # object tops: still there under noise (edges may lose cells)
    assert obj.any() and np.median(np.abs(h - ref)[obj]) < 0.003 and np.abs(h - ref)[obj].mean() < 0.01


def test_knocked_off_counts_objects_that_left_without_a_grasp():
    # Three worlds of 3 object slots.  World 0: one object grasped (3 -> 2 on the table), none
    # knocked off; world 1: a failed grasp and one object gone (2 -> 1); world 2: grasped one
    # and another fell off (3 -> 1).
    from types import SimpleNamespace as NS

    import jax.numpy as jnp

    before = NS(sim=NS(active=jnp.array([[1, 1, 1], [1, 1, 0], [1, 1, 1]], bool)))
    after = NS(sim=NS(active=jnp.array([[1, 1, 0], [1, 0, 0], [1, 0, 0]], bool)))
    lost = VagsEnv.knocked_off(before, after, jnp.array([True, False, True]))
    assert np.asarray(lost).tolist() == [0, 1, 1]
