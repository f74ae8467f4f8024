"""``protocol.redraw_spilled``: rounds whose pile drop spilled an object are drawn again from
their own key sequence, and only those (a scripted reset stands in for the physics, so each
world's spill is a known function of its key)."""
import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from vags_jax.benchmark.protocol import redraw_spilled
from vags_jax.env import where_worlds

P = 4  # object slots per world


@struct.dataclass
class _Sim:
    active: jax.Array  # (B, P) bool
    n_objects: jax.Array  # (B,) int32
    error: jax.Array  # (B,) bool
    key: jax.Array  # (B, 2) the key the world was drawn from


@struct.dataclass
class _State:
    sim: _Sim


def _spills(key) -> jax.Array:
    """Whether the draw of (2,) key spills an object: about half of all draws do."""
    return jax.random.uniform(key) < 0.5


def _reset(keys, counts, obs_key, error_world=None):
    del obs_key
    spill = jax.vmap(_spills)(keys)
    drawn = jnp.arange(P)[None, :] < counts[:, None]
    active = drawn & ~(spill[:, None] & (jnp.arange(P)[None, :] == 0))  # a spill loses slot 0
    error = jnp.zeros(keys.shape[0], bool) if error_world is None else jnp.arange(keys.shape[0]) == error_world
    return _State(sim=_Sim(active=active & ~error[:, None], n_objects=counts, error=error, key=keys))


def _expected(key, tries):
    """(redraws, the key of the kept draw) for one world of key (2,)."""
    for i in range(tries + 1):
        k = key if i == 0 else jax.random.fold_in(key, i)
        if not bool(_spills(k)) or i == tries:
            return i, np.asarray(k)


def test_spilled_rounds_are_drawn_again_from_their_own_keys_until_none_spills():
    keys = jax.random.split(jax.random.PRNGKey(3), 16)
    counts = jnp.full((16,), 3, jnp.int32)
    first = _reset(keys, counts, None)
    assert 3 <= int((first.sim.active.sum(1) < 3).sum()) <= 13  # some spill, some do not

    none, redraws0 = redraw_spilled(_reset, where_worlds, keys, counts, jnp.zeros(2, jnp.uint32), 0)
    np.testing.assert_array_equal(np.asarray(none.sim.key), np.asarray(keys))
    assert (redraws0 == 0).all()

    tries = 6
    state, redraws = redraw_spilled(_reset, where_worlds, keys, counts, jnp.zeros(2, jnp.uint32), tries)
    for w in range(16):
        n, k = _expected(keys[w], tries)
        assert redraws[w] == n
        np.testing.assert_array_equal(np.asarray(state.sim.key[w]), k)
    kept = np.asarray(state.sim.active.sum(1) == 3)
    assert kept[redraws < tries].all() and (redraws > 0).any()

    # A world's scene depends on its own key only: the same worlds alone get the same draws.
    part, redraws_part = redraw_spilled(_reset, where_worlds, keys[5:9], counts[5:9], jnp.zeros(2, jnp.uint32), tries)
    np.testing.assert_array_equal(np.asarray(part.sim.key), np.asarray(state.sim.key[5:9]))
    np.testing.assert_array_equal(redraws_part, redraws[5:9])


def test_a_world_whose_physics_failed_is_not_drawn_again():
    keys = jax.random.split(jax.random.PRNGKey(4), 6)
    counts = jnp.full((6,), 2, jnp.int32)

    def reset(k, c, o):
        return _reset(k, c, o, error_world=2)

    state, redraws = redraw_spilled(reset, where_worlds, keys, counts, jnp.zeros(2, jnp.uint32), 4)
    assert redraws[2] == 0 and bool(state.sim.error[2])
    np.testing.assert_array_equal(np.asarray(state.sim.key[2]), np.asarray(keys[2]))
