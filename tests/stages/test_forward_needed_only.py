"""``net.forward_needed_only``: stage 1's actor runs GDNet only on the worlds that take its greedy
action, and acts as the pass over every world does.  (The pipeline's tests, stages/test_stages.py,
train with it on.)"""
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from vags_jax import batching
from vags_jax import config as C
from vags_jax.stages.stage1 import Stage1


def test_map_in_groups_where_runs_the_needed_items_groups_only():
    calls = []

    def fn(x, y):
        jax.debug.callback(lambda: calls.append(1))
        return {"sum": x.sum(axis=1) + y, "twice": 2 * x}

    x = jnp.arange(7 * 3, dtype=jnp.float32).reshape(7, 3) + 1
    y = jnp.arange(7, dtype=jnp.float32)
    need = jnp.array([False, True, False, False, True, True, False])
    full = fn(x, y)
    calls.clear()
    out = jax.jit(lambda *a: batching.map_in_groups_where(fn, a[:2], 2, a[2]))(x, y, need)
    jax.effects_barrier()
    assert len(calls) == 2  # 3 needed items fill 2 groups of 2; the other 2 of 4 groups are skipped
    n = np.asarray(need)
    for k in ("sum", "twice"):
        got, want = np.asarray(out[k]), np.asarray(full[k])
        np.testing.assert_array_equal(got[n], want[n])
        assert (got[~n] == 0).all()
    with pytest.raises(ValueError, match="need must have shape"):
        batching.map_in_groups_where(fn, (x, y), 2, need[:3])


@pytest.fixture(scope="module")
def stages(fast_cfg):
    """(the pass over every world, the needed-only pass in groups of one world), 2 worlds: the
    reset of the suite's 2-world scenes (conftest's ``fast_cfg``), which the session compiles once."""
    cfg = C.replace(fast_cfg, **{"net.forward_batch": 1})
    every = Stage1(cfg)
    return every, Stage1(C.replace(cfg, **{"net.forward_needed_only": True}), env=every.env)


@pytest.mark.parametrize("bootstrap", ["target_network", "actor"])
def test_the_needed_only_actor_takes_the_same_actions(stages, bootstrap):
    every, needed = stages
    over = {"stage1.bootstrap": bootstrap}
    every = Stage1(C.replace(every.cfg, **over), env=every.env)
    needed = Stage1(C.replace(needed.cfg, **over), env=every.env)
    state = every.init(jax.random.PRNGKey(4))
    grasped = jnp.array([True, False])  # the second world resets
    act0, act1 = jax.jit(every.act), jax.jit(needed.act)
    seen = set()
    for i in range(6):
        key = jax.random.PRNGKey(10 + i)
        a0, x0, q0, v0 = act0(state.learner, state.env, grasped, key, 0.5)
        a1, x1, q1, v1 = act1(state.learner, state.env, grasped, key, 0.5)
        np.testing.assert_array_equal(np.asarray(x1), np.asarray(x0))
        assert np.asarray(v0).all()
        want = np.asarray(grasped) & (True if bootstrap == "actor" else ~np.asarray(x0))
        np.testing.assert_array_equal(np.asarray(v1), want)
        g = np.asarray(grasped)
        np.testing.assert_array_equal(np.asarray(a1)[g], np.asarray(a0)[g])
        np.testing.assert_allclose(np.asarray(q1)[want], np.asarray(q0)[want], rtol=1e-5, atol=1e-6)
        assert (np.asarray(q1)[~want] == 0).all()
        seen.add(int(want.sum()))
    if bootstrap == "target_network":
        assert len(seen) > 1  # the draws varied which worlds made a pass
