"""Spilled piles: ``protocol.redraw_spilled`` draws those rounds again from their own key
sequence, ``protocol.redrop_spilled`` drops their spilled objects again, and only those rounds
(a scripted reset stands in for the physics, so each world's spill is a known function of its
key); then ``VagsEnv.redrop_worlds`` on real physics."""
import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from vags_jax.benchmark.protocol import redraw_spilled, redrop_spilled
from vags_jax.env import where_worlds
from vags_jax.perception import camera

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


def test_spilled_objects_are_dropped_again_keeping_the_draws_and_the_other_worlds():
    """``redrop_spilled``: a world's spilled objects come back after as many drops as its script
    needs; its draws (the key it was drawn from) never change, worlds with nothing spilled and
    worlds whose physics failed are left exactly as they were."""
    keys = jax.random.split(jax.random.PRNGKey(5), 12)
    counts = jnp.full((12,), 3, jnp.int32)
    calls = []

    def reset(k, c, o):
        return _reset(k, c, o, error_world=7)

    def redrop(state, k, c, o):
        calls.append(1)
        back = ~jax.vmap(_spills)(jax.vmap(jax.random.fold_in, (0, None))(k, len(calls)))
        drawn = jnp.arange(P)[None, :] < c[:, None]
        active = jnp.where(back[:, None], drawn, state.sim.active)
        return state.replace(sim=state.sim.replace(active=active))

    first = reset(keys, counts, None)
    state, redrops = redrop_spilled(reset, redrop, where_worlds, keys, counts, jnp.zeros(2, jnp.uint32), 6)
    np.testing.assert_array_equal(np.asarray(state.sim.key), np.asarray(keys))  # the same draws
    spilled0 = np.asarray((first.sim.active.sum(1) < 3) & ~first.sim.error)
    assert spilled0.any() and (~spilled0).any()
    for w in range(12):
        if not spilled0[w]:
            assert redrops[w] == 0
            np.testing.assert_array_equal(np.asarray(state.sim.active[w]), np.asarray(first.sim.active[w]))
            continue
        back = [i for i in range(1, 7) if not bool(_spills(jax.random.fold_in(keys[w], i)))]
        assert redrops[w] == (back[0] if back else 6)
        assert int(state.sim.active[w].sum()) == (3 if back else 2)
    assert redrops[7] == 0 and bool(state.sim.error[7])


def test_redrop_puts_a_spilled_object_back_on_the_table_and_keeps_the_draws(fast_cfg):
    """``VagsEnv.redrop_worlds`` on real physics: an object of world 0 is taken off the table as
    the housekeeping takes one that left the workspace; the re-drop puts it back on the table,
    inside the workspace, in the heightmap, with the world's sizes and colours unchanged; world 1,
    with nothing spilled, keeps every object."""
    from vags_jax.env import VagsEnv

    env = VagsEnv(fast_cfg)
    keys = jax.random.split(jax.random.PRNGKey(0), 2)
    counts = jnp.array([2, 2], jnp.int32)
    obs = jax.random.PRNGKey(1)
    s0 = env.reset_worlds(keys, counts, obs)
    active = np.asarray(s0.sim.active)
    assert active.sum(1).tolist() == [2, 2]
    obj = int(np.flatnonzero(active[0])[0])
    spilled = s0.replace(sim=env.sim.park_objects(s0.sim, jnp.zeros_like(s0.sim.active).at[0, obj].set(True)))
    assert not bool(spilled.sim.active[0, obj])
    again = env.redrop_worlds(spilled, keys, counts, obs)
    assert bool(again.sim.active[0, obj]) and int(again.sim.active.sum()) == 4
    x, y, z = np.asarray(env.sim.object_positions(again.sim))[0, obj]
    xmin, xmax, ymin, ymax = fast_cfg.workspace.bounds
    assert xmin < x < xmax and ymin < y < ymax and z > fast_cfg.workspace.table_z
    assert not bool(again.sim.error.any())
    for a, b in ((again.sim.obj_size, s0.sim.obj_size), (again.sim.geom_rgb, s0.sim.geom_rgb),
                 (again.sim.n_objects, s0.sim.n_objects)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    # The new observation shows it: heightmap cells above the table where the object lies.
    px = camera.world_xy_to_pixel(jnp.array([[x, y]]), fast_cfg.workspace)[0]
    assert float(again.height[0, int(px[0]), int(px[1])]) > fast_cfg.exploration.height_threshold


def test_the_config_takes_one_remedy_and_redrops_only_piles():
    import pytest

    from vags_jax import config as C

    cfg = C.tiny()
    # By default a pile is dropped again; redraws, scattered scenes or an explicit 0 turn that off.
    assert cfg.scene.placement == "pile" and C.spilled_remedy(cfg) == (0, C.DEFAULT_REDROPS) == (0, 10)
    assert C.spilled_remedy(C.replace(cfg, **{"benchmark.redraw_spilled": 3})) == (3, 0)
    assert C.spilled_remedy(C.replace(cfg, **{"scene.placement": "scatter"})) == (0, 0)
    assert C.spilled_remedy(C.replace(cfg, **{"benchmark.redrop_spilled": 0})) == (0, 0)
    assert C.spilled_remedy(C.replace(cfg, **{"benchmark.redrop_spilled": 4})) == (0, 4)
    assert C.spilled_remedy(C.from_saved(C.Config, C.to_dict(cfg))) == (0, 10)  # config.json keeps the default
    with pytest.raises(ValueError, match="set at most one of them"):
        C.replace(cfg, **{"benchmark.redraw_spilled": 2, "benchmark.redrop_spilled": 2})
    with pytest.raises(ValueError, match="needs scene.placement = 'pile'"):
        C.replace(cfg, **{"benchmark.redrop_spilled": 2, "scene.placement": "scatter"})
    with pytest.raises(ValueError, match="redrop_spilled must be a whole number"):
        C.replace(cfg, **{"benchmark.redrop_spilled": -1})
    assert C.replace(cfg, **{"benchmark.redrop_spilled": 10}).benchmark.redrop_spilled == 10


def test_eval_names_spilled_piles_and_the_remedy_in_use():
    from vags_jax.benchmark import metrics as M

    assert M.format_spills({"objects_lost_at_start": 0, "scenes_redrawn": 0}) is None
    assert M.format_spills({}) is None  # reports from before these metrics
    line = M.format_spills({"objects_lost_at_start": 7, "scenes_redrawn": 0})
    assert "7 objects off the table" in line and "benchmark.redrop_spilled=N" in line
    line = M.format_spills({"objects_lost_at_start": 1, "scenes_redrawn": 5}, redraw=10)
    assert line.startswith("spilled piles: 5 rounds redone (benchmark.redraw_spilled=10); 1 object still")
    assert "redrop_spilled=3" in M.format_spills({"objects_lost_at_start": 0, "scenes_redrawn": 2}, redrop=3)
