"""Prioritized replay: hand-computed expectations (ring buffer, priorities, sampling, IS weights)."""
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from vags_jax.rl import replay


def _scalar_buffer(capacity):
    return replay.init(capacity, {"x": jnp.zeros((), jnp.float32), "v": jnp.zeros((2,), jnp.int32)})


def _items(values):
    values = jnp.asarray(values, jnp.float32)
    return {"x": values, "v": jnp.stack([values, -values], -1).astype(jnp.int32)}


def test_init_shapes_and_dtypes():
    h = w = 8
    example = replay.make_grasp_transition(
        jnp.zeros((h, w, 3)), jnp.zeros((h, w)), jnp.zeros((3,)), 0.0,
        jnp.zeros((h, w, 3)), jnp.zeros((h, w)), False)
    st = replay.init(5, example)
    assert st.capacity == 5
    assert st.data.color.shape == (5, h, w, 3) and st.data.color.dtype == jnp.uint8
    assert st.data.height.shape == (5, h, w) and st.data.height.dtype == jnp.float16
    assert st.data.action.shape == (5, 3) and st.data.action.dtype == jnp.int32
    assert st.data.reward.shape == (5,) and st.data.done.dtype == jnp.bool_
    assert int(st.size) == 0 and int(st.insert_pos) == 0 and float(st.max_priority) == 1.0
    # 2 * 192 (uint8 colour) + 2 * 128 (f16 height) + 12 + 4 + 1 = 657 B per item, + 4 B priority
    assert replay.nbytes(st) == 5 * (657 + 4) + 4 + 4 + 4


def test_ring_buffer_wraparound():
    st = _scalar_buffer(5)
    add = jax.jit(replay.add)
    st = add(st, _items([0, 1, 2]))
    assert int(st.size) == 3 and int(st.insert_pos) == 3
    st = add(st, _items([3, 4, 5]))  # slots 3, 4, then wraps to 0
    assert int(st.size) == 5 and int(st.insert_pos) == 1
    np.testing.assert_array_equal(st.data["x"], [5, 1, 2, 3, 4])
    np.testing.assert_array_equal(st.data["v"][:, 1], [-5, -1, -2, -3, -4])
    st = add(st, _items([6, 7, 8]))
    assert int(st.size) == 5 and int(st.insert_pos) == 4
    np.testing.assert_array_equal(st.data["x"], [5, 6, 7, 8, 4])


def test_masked_add_packs_the_kept_items_and_wraps():
    st = _scalar_buffer(5)
    add = jax.jit(replay.add)
    st = add(st, _items([0, 1, 2, 3]), jnp.array([True, False, True, False]))
    assert int(st.size) == 2 and int(st.insert_pos) == 2
    np.testing.assert_array_equal(st.data["x"][:2], [0, 2])
    st = st.replace(priorities=st.priorities.at[0].set(0.25))
    st = add(st, _items([4, 5, 6, 7]), jnp.array([False, True, True, True]))  # slots 2, 3, 4
    assert int(st.size) == 5 and int(st.insert_pos) == 0
    np.testing.assert_array_equal(st.data["x"], [0, 2, 5, 6, 7])
    np.testing.assert_array_equal(st.priorities, [0.25, 1, 1, 1, 1])  # dropped items wrote nothing
    st = add(st, _items([8, 9]), jnp.array([False, False]))
    assert int(st.size) == 5 and int(st.insert_pos) == 0
    np.testing.assert_array_equal(st.data["x"], [0, 2, 5, 6, 7])
    st = add(st, _items([10, 11]), jnp.array([True, True]))  # wraps over the oldest
    np.testing.assert_array_equal(st.data["x"], [10, 11, 5, 6, 7])


def test_add_more_than_capacity_raises():
    with pytest.raises(ValueError, match="capacity"):
        replay.add(_scalar_buffer(2), _items([0, 1, 2]))


def test_priority_update_and_new_items_get_max_priority():
    st = replay.add(_scalar_buffer(6), _items([0, 1, 2]))
    np.testing.assert_allclose(st.priorities, [1, 1, 1, 0, 0, 0])
    st = replay.update_priorities(st, jnp.array([0, 2]), jnp.array([-2.0, 0.5]), 0.01)
    np.testing.assert_allclose(st.priorities, [2.01, 1, 0.51, 0, 0, 0], rtol=1e-6)
    np.testing.assert_allclose(st.max_priority, 2.01, rtol=1e-6)
    st = replay.add(st, _items([3, 4]))
    np.testing.assert_allclose(st.priorities, [2.01, 1, 0.51, 2.01, 2.01, 0], rtol=1e-6)
    # A smaller update does not lower max_priority.
    st = replay.update_priorities(st, jnp.array([3]), jnp.array([0.0]), 0.01)
    np.testing.assert_allclose(st.max_priority, 2.01, rtol=1e-6)
    np.testing.assert_allclose(st.priorities[3], 0.01, rtol=1e-6)


def _is_weights_by_hand(priorities, alpha, beta, sampled):
    """Prioritized-replay importance weights computed from the definition (Schaul et al. 2016),
    one item at a time in plain Python, independently of ``replay.sample``'s vectorised code:
    P(i) = p_i^alpha / sum_k p_k^alpha over the N valid items, w_i = (N P(i))^-beta, and every
    weight divided by the largest weight among the items in the sampled batch."""
    n = len(priorities)
    total = sum(p ** alpha for p in priorities)
    prob = [p ** alpha / total for p in priorities]
    raw = {i: (n * prob[i]) ** (-beta) for i in sorted(set(sampled))}
    biggest = max(raw.values())
    return {i: w / biggest for i, w in raw.items()}


# Hand-worked importance weights for priorities 1, 2, 3, 4 (N = 4) and beta = 0.5:
#   alpha = 1:   P = .1 .2 .3 .4;  N P = .4 .8 1.2 1.6;  (N P)^-1/2 = 1.5811 1.1180 .91287 .79057
#                -> / 1.5811 = 1, .70711, .57735, .5
#   alpha = 0.5: p^.5 = 1 1.41421 1.73205 2 (sum 6.14626);  N P = .65080 .92037 1.12722 1.30160;
#                (N P)^-1/2 = 1.23958 1.04236 .94188 .87652 -> / 1.23958 = 1, .84090, .75984, .70711
@pytest.mark.parametrize("alpha,hand_weights", [
    (1.0, [1.0, 0.70711, 0.57735, 0.5]),
    (0.5, [1.0, 0.84090, 0.75984, 0.70711]),
])
def test_sampling_frequencies_and_importance_weights(alpha, hand_weights):
    # Capacity 8, 4 valid items with priorities 1, 2, 3, 4; slots 4..7 never written.
    priorities = [1.0, 2.0, 3.0, 4.0]
    st = replay.add(_scalar_buffer(8), _items([10, 11, 12, 13]))
    st = replay.update_priorities(st, jnp.arange(4), jnp.array(priorities), 0.0)
    n = 20_000
    beta = 0.5
    sample = jax.jit(replay.sample, static_argnums=2)
    idx, batch, w = sample(st, jax.random.key(0), n, alpha, beta)
    idx = np.asarray(idx)
    assert idx.min() >= 0 and idx.max() <= 3  # never an unwritten slot
    np.testing.assert_array_equal(np.asarray(batch["x"]), 10 + idx)

    p = np.array(priorities) ** alpha
    probs = p / p.sum()  # alpha=1: .1 .2 .3 .4
    counts = np.bincount(idx, minlength=4)
    chi2 = ((counts - n * probs) ** 2 / (n * probs)).sum()
    assert chi2 < 21.1, (counts, n * probs)  # 3 dof, p = 1e-4

    # Every draw's weight is the one worked out by hand above and by the definition.
    by_hand = _is_weights_by_hand(priorities, alpha, beta, idx.tolist())
    np.testing.assert_allclose([by_hand[i] for i in range(4)], hand_weights, rtol=1e-4)
    w = np.asarray(w)
    for i in range(4):
        np.testing.assert_allclose(w[idx == i], hand_weights[i], rtol=1e-4)
        np.testing.assert_allclose(w[idx == i], by_hand[i], rtol=1e-5)


def test_importance_weights_hand_computed_small_batch():
    # Priorities 1, 3 with alpha = 1 -> P = 1/4, 3/4, N = 2: raw w = (1/2)^-1 = 2 and (3/2)^-1 = 2/3.
    st = replay.add(_scalar_buffer(4), _items([0, 1]))
    st = replay.update_priorities(st, jnp.arange(2), jnp.array([1.0, 3.0]), 0.0)
    idx, _, w = replay.sample(st, jax.random.key(3), 64, 1.0, 1.0)
    idx, w = np.asarray(idx), np.asarray(w)
    assert set(idx.tolist()) == {0, 1}
    np.testing.assert_allclose(w[idx == 0], 1.0, rtol=1e-6)
    np.testing.assert_allclose(w[idx == 1], 1.0 / 3.0, rtol=1e-6)
    # beta = 0: uniform weights.
    _, _, w0 = replay.sample(st, jax.random.key(3), 64, 1.0, 0.0)
    np.testing.assert_allclose(w0, 1.0)


def test_importance_weights_are_normalised_by_the_batch_maximum():
    # Priorities 0, 1, 1, 2 (alpha = beta = 1, N = 4): P = 0, 1/4, 1/4, 1/2, so N P = 0, 1, 1, 2
    # and raw w = inf, 1, 1, 1/2.  Item 0 is never drawn (probability 0); dividing by the largest
    # weight *in the batch* gives 1, 1, 1/2 -- dividing by the largest over the buffer would give
    # 0 everywhere.
    st = replay.add(_scalar_buffer(4), _items([0, 1, 2, 3]))
    st = replay.update_priorities(st, jnp.arange(4), jnp.array([0.0, 1.0, 1.0, 2.0]), 0.0)
    idx, _, w = replay.sample(st, jax.random.key(5), 64, 1.0, 1.0)
    idx, w = np.asarray(idx), np.asarray(w)
    assert 0 not in set(idx.tolist()) and set(idx.tolist()) == {1, 2, 3}
    for i, expected in ((1, 1.0), (2, 1.0), (3, 0.5)):
        np.testing.assert_allclose(w[idx == i], expected, rtol=1e-6)


def test_alpha_zero_is_uniform_over_valid_slots():
    st = replay.add(_scalar_buffer(8), _items([0, 1, 2]))
    st = replay.update_priorities(st, jnp.arange(3), jnp.array([1.0, 100.0, 5.0]), 0.0)
    idx, _, w = replay.sample(st, jax.random.key(1), 3000, 0.0, 0.4)
    counts = np.bincount(np.asarray(idx), minlength=8)
    assert counts[3:].sum() == 0
    np.testing.assert_allclose(counts[:3] / 3000, 1 / 3, atol=0.04)
    np.testing.assert_allclose(w, 1.0, rtol=1e-6)


def test_heightmap_compression_roundtrip():
    h = jnp.linspace(0.0, 0.5, 1001, dtype=jnp.float32).reshape(7, 143)
    c = replay.compress_heightmap(h)
    assert c.dtype == jnp.float16
    back = replay.decompress(c)
    assert back.dtype == jnp.float32 and back.shape == h.shape
    assert float(jnp.max(jnp.abs(back - h))) < 1.3e-4  # half a float16 ulp at [0.25, 0.5)
    bf = replay.decompress(replay.compress_heightmap(h, jnp.bfloat16))
    assert float(jnp.max(jnp.abs(bf - h))) < 1.0e-3
    col = replay.compress_color(jnp.array([[-3.0, 12.4, 254.6, 300.0]]))
    np.testing.assert_array_equal(col, [[0, 12, 255, 255]])
    assert col.dtype == jnp.uint8


def test_repeated_indices_take_the_largest_priority():
    state = replay.init(4, jnp.zeros((2,)))
    state = replay.add(state, jnp.zeros((4, 2)))
    idx = jnp.array([1, 1, 1, 3])
    td = jnp.array([0.5, -2.0, 1.0, 0.25])
    out = replay.update_priorities(state, idx, td, eps=0.0)
    np.testing.assert_allclose(np.asarray(out.priorities), [1.0, 2.0, 1.0, 0.25])
    assert float(out.max_priority) == 2.0


def _valued(worlds, done=None):
    """Actor-bootstrap items from ``worlds`` worlds (4 x 4 maps): reward = world index."""
    k = worlds
    return replay.make_valued_transition(jnp.zeros((k, 4, 4, 3)), jnp.zeros((k, 4, 4)), jnp.zeros((k, 3), jnp.int32),
                                         jnp.arange(k, dtype=jnp.float32),
                                         jnp.zeros((k,), bool) if done is None else done)


def test_pending_items_are_never_sampled_until_their_values_come():
    example = jax.tree.map(lambda x: x[0], _valued(1))
    st = replay.init(6, example)
    add = jax.jit(lambda s, t, m: replay.add(s, t, m, pending=True))
    fill = jax.jit(replay.fill_pending_values)
    # Iteration 0: worlds 0, 2 and 3 of 4 grasp (world 1 resets).
    st = add(st, _valued(4), jnp.array([True, False, True, True]))
    assert int(st.size) == 3 and int(replay.sampleable(st)) == 0
    np.testing.assert_array_equal(st.data.world[:3], [0, 2, 3])
    np.testing.assert_array_equal(st.priorities[:3], [0, 0, 0])
    # Iteration 1: the actor's max Q of each world's state fills those three, by world.
    values = jnp.array([10.0, 11.0, 12.0, 13.0])
    st = fill(st, values)
    np.testing.assert_array_equal(st.data.next_value[:3], [10, 12, 13])
    np.testing.assert_array_equal(st.priorities[:3], [1, 1, 1])  # max_priority: sampleable now
    assert int(replay.sampleable(st)) == 3
    st = replay.update_priorities(st, jnp.array([0, 1, 2]), jnp.array([0.5, 2.0, 0.1]), 1e-3)
    # Iteration 1's own attempts (worlds 1 and 3), written over the ring's end: still pending.
    st = add(st, _valued(4), jnp.array([False, True, False, True]))
    before = np.asarray(st.priorities)
    for k in jax.random.split(jax.random.key(0), 50):
        idx, _, w = replay.sample(st, k, 8, 0.6, 0.4)
        assert set(np.asarray(idx).tolist()) <= {0, 1, 2}
        assert np.isfinite(np.asarray(w)).all()
    # Iteration 2: only iteration 1's two items take values; the older three keep theirs.
    st = fill(st, jnp.array([20.0, 21.0, 22.0, 23.0]))
    np.testing.assert_array_equal(st.data.next_value[:5], [10, 12, 13, 21, 23])
    np.testing.assert_array_equal(st.priorities[:3], before[:3])
    np.testing.assert_allclose(st.priorities[3:5], [float(st.max_priority)] * 2)
    # Wrapped: four more pending items fill slots 5, 0, 1, 2; then only they take values.
    st = add(st, _valued(4), jnp.ones(4, bool))
    assert int(st.insert_pos) == 3 and int(replay.sampleable(st)) == 2  # slots 3 and 4
    st = fill(st, jnp.array([30.0, 31.0, 32.0, 33.0]))
    np.testing.assert_array_equal(st.data.next_value, [31, 32, 33, 21, 23, 30])
    assert int(replay.sampleable(st)) == 6


def test_pending_items_take_their_worlds_next_action():
    """``fill_pending_actions`` (``stage1.bootstrap = "actor_argmax"``): the last add's pending
    items take their own world's greedy action and become sampleable; older items keep theirs."""
    k = 3
    z = jnp.zeros((k, 2, 2, 3))
    def items():
        return replay.make_argmax_transition(z, z[..., 0], jnp.zeros((k, 3), jnp.int32), jnp.ones((k,)), z, z[..., 0],
                                             jnp.zeros((k,), bool))
    st = replay.init(5, jax.tree.map(lambda x: x[0], items()))
    st = replay.add(st, items(), jnp.array([False, True, True]), pending=True)  # worlds 1 and 2
    assert int(replay.sampleable(st)) == 0 and st.data.next_color.shape == (5, 2, 2, 3)
    acts = jnp.array([[1, 0, 0], [2, 1, 0], [3, 0, 1]], jnp.int32)
    st = replay.fill_pending_actions(st, acts)
    np.testing.assert_array_equal(st.data.next_action[:2], [[2, 1, 0], [3, 0, 1]])
    assert int(replay.sampleable(st)) == 2
    st = replay.add(st, items(), jnp.array([True, False, False]), pending=True)  # world 0
    st = replay.fill_pending_actions(st, acts[::-1])
    np.testing.assert_array_equal(st.data.next_action[:3], [[2, 1, 0], [3, 0, 1], [3, 0, 1]])
    assert int(replay.sampleable(st)) == 3
