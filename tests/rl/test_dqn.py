"""DQN pieces: hand-computed Huber loss / gradients / targets, optimizer, and the update step."""
import dataclasses

import flax.linen as nn
import jax
import jax.numpy as jnp
import numpy as np
import optax
import pytest

from vags_jax.rl import dqn, replay
from vags_jax.config import DQN

R, H, W = 4, 8, 8


# ----------------------------------------------------------------------------- loss and targets


def _q_and_actions():
    q = jnp.zeros((2, R, H, W))
    q = q.at[0, 1, 2, 3].set(0.3).at[1, 3, 7, 0].set(-1.0)
    action = jnp.array([[1, 2, 3], [3, 7, 0]], jnp.int32)
    return q, action


def test_huber_at_action_values():
    q, action = _q_and_actions()
    y = jnp.array([1.0, 2.0])
    # item 0: e = 0.7 < delta -> 0.5 * 0.49 = 0.245; item 1: e = 3 > delta -> 1 * (3 - 0.5) = 2.5
    loss, td = dqn.huber_loss_at_action(q, action, y, jnp.ones(2), 1.0)
    np.testing.assert_allclose(td, [0.7, 3.0], rtol=1e-6)
    np.testing.assert_allclose(loss, (0.245 + 2.5) / 2, rtol=1e-6)
    loss, _ = dqn.huber_loss_at_action(q, action, y, jnp.array([1.0, 0.5]), 1.0)
    np.testing.assert_allclose(loss, (0.245 + 1.25) / 2, rtol=1e-6)
    # delta = 2: item 1 becomes 2 * (3 - 1) = 4.
    loss, _ = dqn.huber_loss_at_action(q, action, y, jnp.ones(2), 2.0)
    np.testing.assert_allclose(loss, (0.245 + 4.0) / 2, rtol=1e-6)


def test_huber_gradient_only_at_executed_action():
    q, action = _q_and_actions()
    y = jnp.array([1.0, 2.0])
    w = jnp.array([1.0, 0.5])
    g = jax.grad(lambda q: dqn.huber_loss_at_action(q, action, y, w, 1.0)[0])(q)
    expected = np.zeros(q.shape, np.float32)
    expected[0, 1, 2, 3] = -0.7 * 1.0 / 2  # d/dq 0.5 (y - q)^2 = -(y - q), times w / b
    expected[1, 3, 7, 0] = -1.0 * 0.5 / 2  # beyond delta: -delta * sign(e), times w / b
    np.testing.assert_allclose(g, expected, rtol=1e-6, atol=0)


def test_symmetric_label_adds_mirrored_rotation():
    q = jnp.zeros((1, R, 2, 2))
    action = jnp.array([[1, 0, 1]], jnp.int32)
    f = lambda q: dqn.huber_loss_at_action(q, action, jnp.array([1.0]), jnp.ones(1), 1.0, symmetric=True)
    (loss, td), g = jax.value_and_grad(f, has_aux=True)(q)
    np.testing.assert_allclose(loss, 0.5 + 0.5)
    np.testing.assert_allclose(td, [1.0])
    expected = np.zeros(q.shape, np.float32)
    expected[0, 1, 0, 1] = expected[0, 3, 0, 1] = -1.0  # rotation 1 and (1 + 4/2) % 4 = 3
    np.testing.assert_allclose(g, expected)


def test_huber_vanet_shapes():
    q = jnp.zeros((2, H, W)).at[1, 4, 5].set(2.5)
    loss, td = dqn.huber_loss_at_action(q, jnp.array([[0, 0], [4, 5]]), jnp.array([0.5, 2.0]),
                                        jnp.ones(2), 1.0)
    np.testing.assert_allclose(td, [0.5, -0.5])
    np.testing.assert_allclose(loss, 0.125)
    with pytest.raises(ValueError):
        dqn.huber_loss_at_action(q, jnp.zeros((2, 3), jnp.int32), jnp.zeros(2), jnp.ones(2), 1.0)


def test_td_target_with_done():
    next_q = jnp.zeros((3, R, H, W)).at[0, 2, 1, 1].set(2.0).at[1, 0, 5, 6].set(3.0)
    next_q = next_q.at[2, 3, 3, 3].set(5.0)
    y = dqn.td_target(jnp.array([1.0, 0.0, 1.0]), jnp.array([False, False, True]), next_q, 0.5)
    np.testing.assert_allclose(y, [1 + 0.5 * 2, 0 + 0.5 * 3, 1.0])
    # VANet (b, H, W); max is over the whole map, including a negative map.
    nq = jnp.full((2, H, W), -4.0).at[0, 0, 0].set(-1.0).at[1, 2, 2].set(6.0)
    y = dqn.td_target(jnp.array([0.0, 2.0]), jnp.array([False, False]), nq, 0.5)
    np.testing.assert_allclose(y, [-0.5, 5.0])


def test_double_q_target():
    online = jnp.zeros((2, H, W)).at[0, 1, 1].set(9.0).at[1, 2, 2].set(9.0)
    target = jnp.zeros((2, H, W)).at[0, 1, 1].set(2.0).at[0, 5, 5].set(7.0).at[1, 2, 2].set(4.0)
    y = dqn.double_q_td_target(jnp.array([1.0, 1.0]), jnp.array([False, True]), target, online, 0.5)
    np.testing.assert_allclose(y, [1 + 0.5 * 2.0, 1.0])  # target value at the ONLINE argmax


def test_sgd_is_pytorch_style_l2_with_momentum():
    cfg = DQN(optimizer="sgd", learning_rate=0.1, momentum=0.9, weight_decay=0.01)
    tx = dqn.make_optimizer(cfg)
    p = {"w": jnp.array([1.0])}
    g = {"w": jnp.array([2.0])}
    s = tx.init(p)
    u, s = tx.update(g, s, p)
    # g' = g + wd * p = 2.01; buf = g'; update = -lr * buf
    np.testing.assert_allclose(u["w"], [-0.1 * 2.01], rtol=1e-6)
    p = optax.apply_updates(p, u)  # 0.799
    u, s = tx.update(g, s, p)
    # g' = 2 + 0.01 * 0.799 = 2.00799; buf = 0.9 * 2.01 + 2.00799
    np.testing.assert_allclose(u["w"], [-0.1 * (0.9 * 2.01 + 2.00799)], rtol=1e-6)


# ----------------------------------------------------------------------------- update step


class TinyQ(nn.Module):
    """Two convs with BatchNorm: (B,H,W,3) uint8 + (B,H,W) -> (B,R,H,W), or (B,H,W) if n_rot == 0."""

    n_rot: int = R

    @nn.compact
    def __call__(self, color, height, train):
        x = jnp.concatenate([color.astype(jnp.float32) / 255.0, height[..., None] * 10.0], -1)
        x = nn.relu(nn.BatchNorm(use_running_average=not train, momentum=0.5)(nn.Conv(8, (3, 3))(x)))
        x = nn.Conv(max(self.n_rot, 1), (1, 1))(x)
        return x.transpose(0, 3, 1, 2) if self.n_rot else x[..., 0]


def _batch(key, b, action_dim, done):
    ks = jax.random.split(key, 6)
    hi = jnp.array([R, H, W]) if action_dim == 3 else jnp.array([H, W])
    return replay.make_grasp_transition(
        color=jax.random.randint(ks[0], (b, H, W, 3), 0, 256),
        height=jax.random.uniform(ks[1], (b, H, W)) * 0.05,
        action=jax.random.randint(ks[2], (b, action_dim), 0, hi),
        reward=jax.random.bernoulli(ks[3], 0.5, (b,)).astype(jnp.float32),
        next_color=jax.random.randint(ks[4], (b, H, W, 3), 0, 256),
        next_height=jax.random.uniform(ks[5], (b, H, W)) * 0.05,
        done=done,
    )


def _allclose_tree(a, b):
    return all(bool(jnp.allclose(x, y)) for x, y in zip(jax.tree.leaves(a), jax.tree.leaves(b)))


def test_update_step_reduces_loss_and_syncs_target():
    cfg = DQN(optimizer="adam", learning_rate=1e-2, weight_decay=0.0, target_update_period=3)
    net = TinyQ()
    b = 8
    batch = _batch(jax.random.key(0), b, 3, jnp.ones(b, bool))  # terminal: fixed targets y = r
    variables = net.init(jax.random.key(1), batch.color, batch.height.astype(jnp.float32), False)
    ts = dqn.create_train_state(variables, cfg)
    init_params, init_stats = ts.params, ts.batch_stats
    update = jax.jit(dqn.make_update_step(net.apply, cfg))
    w = jnp.ones(b)

    losses, snapshots, synced = [], [], []
    for _ in range(12):
        ts, metrics, td = update(ts, batch, w)
        losses.append(float(metrics["loss"]))
        synced.append(bool(metrics["target_synced"]))
        snapshots.append(ts)
    assert td.shape == (b,)
    assert losses[-1] < 0.5 * losses[0], losses
    assert int(ts.step) == 12
    assert not _allclose_tree(ts.batch_stats, init_stats)  # BN statistics were updated

    s1, s2, s3, s4 = snapshots[:4]
    assert _allclose_tree(s1.target_params, init_params) and _allclose_tree(s2.target_params, init_params)
    assert not _allclose_tree(s2.params, init_params)
    assert _allclose_tree(s3.target_params, s3.params)  # copied at step 3
    assert _allclose_tree(s3.target_batch_stats, s3.batch_stats)
    assert _allclose_tree(s4.target_params, s3.params) and not _allclose_tree(s4.target_params, s4.params)
    assert synced == [False, False, True] * 4


def test_update_step_vanet_double_q_matches_manual_td():
    cfg = DQN(double_q=True, gamma=0.5, target_update_period=100)  # paper SGD defaults
    net = TinyQ(n_rot=0)
    b = 4
    batch = _batch(jax.random.key(2), b, 2, jnp.array([False, True, False, False]))
    variables = net.init(jax.random.key(3), batch.color, batch.height.astype(jnp.float32), False)
    ts = dqn.create_train_state(variables, cfg)
    # Make the target differ from the online net so double-Q matters.
    ts = ts.replace(target_params=jax.tree.map(lambda x: x * 1.5, ts.target_params))
    new_ts, metrics, td = jax.jit(dqn.make_update_step(net.apply, cfg))(ts, batch, jnp.ones(b))

    nh = batch.next_height.astype(jnp.float32)
    q_t = net.apply({"params": ts.target_params, "batch_stats": ts.target_batch_stats},
                    batch.next_color, nh, False)
    q_o = net.apply({"params": ts.params, "batch_stats": ts.batch_stats}, batch.next_color, nh, False)
    a = q_o.reshape(b, -1).argmax(-1)
    y = batch.reward + 0.5 * np.where(batch.done, 0.0, np.asarray(q_t.reshape(b, -1))[np.arange(b), a])
    q, _ = net.apply({"params": ts.params, "batch_stats": ts.batch_stats}, batch.color,
                     batch.height.astype(jnp.float32), True, mutable=["batch_stats"])
    expected_td = y - np.asarray(q)[np.arange(b), batch.action[:, 0], batch.action[:, 1]]
    np.testing.assert_allclose(td, expected_td, rtol=1e-4, atol=1e-5)
    np.testing.assert_allclose(metrics["target_mean"], y.mean(), rtol=1e-5)
    assert int(new_ts.step) == 1 and not bool(metrics["target_synced"])
    assert not _allclose_tree(new_ts.params, ts.params)


# ----------------------------------------------------------------------------- executed rotation only


def _rotation_net(variables, color, height, train, mutable=False, rotations=None):
    """BatchNorm-free stand-in for GDNet: q[b, r] = w[r] * height[b] + c[r] * mean colour[b].

    With ``rotations`` (b, K) it returns only those rotations, (b, K, H, W), like GDNet.
    """
    p = variables["params"]
    grey = color.astype(jnp.float32).mean(-1) / 255.0  # (b, H, W)
    w, c = p["w"], p["c"]  # (R,)
    if rotations is None:
        q = w[None, :, None, None] * height[:, None] + c[None, :, None, None] * grey[:, None]
    else:
        q = w[rotations][..., None, None] * height[:, None] + c[rotations][..., None, None] * grey[:, None]
    return (q, {"batch_stats": {}}) if mutable else q


@pytest.mark.parametrize("symmetric", [False, True])
def test_executed_rotation_only_matches_full_evaluation(symmetric):
    rng = np.random.default_rng(0)
    b = 5
    batch = replay.GraspTransition(
        color=jnp.asarray(rng.integers(0, 256, (b, H, W, 3)), jnp.uint8),
        height=jnp.asarray(rng.uniform(0, 0.1, (b, H, W)), jnp.float16),
        action=jnp.asarray(np.stack([rng.integers(0, R, b), rng.integers(0, H, b), rng.integers(0, W, b)], 1), jnp.int32),
        reward=jnp.asarray(rng.integers(0, 2, b), jnp.float32),
        next_color=jnp.asarray(rng.integers(0, 256, (b, H, W, 3)), jnp.uint8),
        next_height=jnp.asarray(rng.uniform(0, 0.1, (b, H, W)), jnp.float16),
        done=jnp.asarray([False, True, False, False, True]),
    )
    weights = jnp.asarray(rng.uniform(0.2, 1.0, b), jnp.float32)
    variables = {"params": {"w": jnp.asarray(rng.normal(size=R), jnp.float32),
                            "c": jnp.asarray(rng.normal(size=R), jnp.float32)}, "batch_stats": {}}
    cfg = DQN(optimizer="sgd", learning_rate=0.1, symmetric_grasp_label=symmetric)
    ts = dqn.create_train_state(variables, cfg)
    full = jax.jit(dqn.make_update_step(_rotation_net, cfg))(ts, batch, weights)
    sub = jax.jit(dqn.make_update_step(_rotation_net, cfg, executed_rotation_only=True))(ts, batch, weights)
    np.testing.assert_allclose(sub[1]["loss"], full[1]["loss"], rtol=1e-6)
    np.testing.assert_allclose(sub[2], full[2], rtol=1e-6)  # td errors
    np.testing.assert_allclose(sub[1]["q_taken_mean"], full[1]["q_taken_mean"], rtol=1e-6)
    for k in ("w", "c"):
        np.testing.assert_allclose(sub[0].params[k], full[0].params[k], rtol=1e-6, atol=1e-7)
    assert not np.allclose(full[0].params["w"], variables["params"]["w"])  # the update did move


def _six_random_grasps(rng):
    """Six random grasp transitions (two terminal), ``_rotation_net``'s random variables, and a
    train state of them at gamma 0.5 with symmetric labels -> (batch, DQN config, train state)."""
    b = 6
    grasp = replay.make_grasp_transition(
        rng.integers(0, 256, (b, H, W, 3)), rng.uniform(0, 0.1, (b, H, W)),
        np.stack([rng.integers(0, R, b), rng.integers(0, H, b), rng.integers(0, W, b)], 1),
        rng.integers(0, 2, b).astype(np.float32), rng.integers(0, 256, (b, H, W, 3)), rng.uniform(0, 0.1, (b, H, W)),
        np.array([False, True, False, False, True, False]))
    variables = {"params": {"w": jnp.asarray(rng.normal(size=R), jnp.float32),
                            "c": jnp.asarray(rng.normal(size=R), jnp.float32)}, "batch_stats": {}}
    cfg = DQN(optimizer="sgd", learning_rate=0.1, gamma=0.5, symmetric_grasp_label=True)
    return grasp, cfg, dqn.create_train_state(variables, cfg)


def test_a_stored_bootstrap_value_gives_the_target_networks_update():
    """``stage1.bootstrap = "actor"``: a batch that carries max Q of its next states as values
    updates exactly as the target network's pass over those states would (rotation subset and
    symmetric labels, which then take R from ``n_rotations``)."""
    rng = np.random.default_rng(1)
    b = 6
    grasp, cfg, ts = _six_random_grasps(rng)
    ts = ts.replace(target_params=jax.tree.map(lambda x: 0.7 * x, ts.target_params))  # target != online
    v = _rotation_net({"params": ts.target_params}, grasp.next_color, grasp.next_height.astype(jnp.float32), False)
    valued = replay.make_valued_transition(grasp.color, grasp.height, grasp.action, grasp.reward, grasp.done)
    valued = valued.replace(next_value=v.reshape(b, -1).max(-1))
    w = jnp.asarray(rng.uniform(0.2, 1.0, b), jnp.float32)
    target = jax.jit(dqn.make_update_step(_rotation_net, cfg, executed_rotation_only=True))(ts, grasp, w)
    stored_update = jax.jit(dqn.make_update_step(_rotation_net, cfg, executed_rotation_only=True, n_rotations=R))
    stored = stored_update(ts, valued, w)
    np.testing.assert_allclose(stored[1]["target_mean"], target[1]["target_mean"], rtol=1e-6)
    np.testing.assert_allclose(stored[2], target[2], rtol=1e-6)
    for k in ("w", "c"):
        np.testing.assert_allclose(stored[0].params[k], target[0].params[k], rtol=1e-6)
    # A terminal item's value is ignored: y = r there (the batch holds two terminal items).
    assert int(np.sum(np.asarray(grasp.done))) == 2
    huge = valued.replace(next_value=jnp.where(valued.done, 1e6, valued.next_value))
    np.testing.assert_allclose(stored_update(ts, huge, w)[2], stored[2], rtol=1e-6)
    # Symmetric labels without n_rotations have no R to mirror by: a clear error.
    with pytest.raises(ValueError, match="n_rotations"):
        dqn.make_update_step(_rotation_net, cfg, executed_rotation_only=True)(ts, valued, w)


def test_the_actors_argmax_gives_double_qs_target():
    """``stage1.bootstrap = "actor_argmax"``: a batch that carries the online network's argmax on
    its next states updates exactly as Double DQN's update (target network's pass over every
    rotation, online network's argmax) would, from a target pass over one rotation per state."""
    rng = np.random.default_rng(2)
    b = 6
    grasp, cfg, ts = _six_random_grasps(rng)
    # A target network whose argmax differs from the online one's: the rotations' weights reversed.
    ts = ts.replace(target_params=jax.tree.map(lambda x: x[::-1], ts.target_params))
    next_h = grasp.next_height.astype(jnp.float32)
    online_q = _rotation_net({"params": ts.params}, grasp.next_color, next_h, False)
    target_q = _rotation_net({"params": ts.target_params}, grasp.next_color, next_h, False)
    greedy = jnp.stack(jnp.unravel_index(jnp.argmax(online_q.reshape(b, -1), -1), (R, H, W)), -1).astype(jnp.int32)
    assert not np.array_equal(np.asarray(greedy), np.stack(np.unravel_index(
        np.asarray(target_q).reshape(b, -1).argmax(-1), (R, H, W)), -1))  # the two nets disagree
    stored = replay.make_argmax_transition(grasp.color, grasp.height, grasp.action, grasp.reward, grasp.next_color,
                                           grasp.next_height, grasp.done).replace(next_action=greedy)
    w = jnp.asarray(rng.uniform(0.2, 1.0, b), jnp.float32)
    calls = []

    def counting_net(variables, color, height, train, mutable=False, rotations=None):
        calls.append(None if rotations is None else rotations.shape)
        return _rotation_net(variables, color, height, train, mutable, rotations)

    double = dqn.make_update_step(_rotation_net, dataclasses.replace(cfg, double_q=True),
                                  executed_rotation_only=True)(ts, grasp, w)
    update = jax.jit(dqn.make_update_step(counting_net, cfg, executed_rotation_only=True, n_rotations=R))
    out = update(ts, stored, w)
    assert calls[0] == (b, 1)  # the target pass: one rotation of each next state
    np.testing.assert_allclose(out[1]["target_mean"], double[1]["target_mean"], rtol=1e-6)
    np.testing.assert_allclose(out[2], double[2], rtol=1e-6)
    for k in ("w", "c"):
        np.testing.assert_allclose(out[0].params[k], double[0].params[k], rtol=1e-6)
    # By hand: y = r + 0.5 * Q_target(s', stored action), r alone where done.
    tq = np.asarray(target_q)
    a = np.asarray(greedy)
    y = np.asarray(grasp.reward) + 0.5 * np.where(np.asarray(grasp.done), 0.0, tq[np.arange(b), a[:, 0], a[:, 1], a[:, 2]])
    np.testing.assert_allclose(float(out[1]["target_mean"]), y.mean(), rtol=1e-6)
    # Another stored action reads another value: the target follows the stored action.
    moved = stored.replace(next_action=stored.next_action.at[:, 0].set((greedy[:, 0] + 1) % R))
    assert not np.allclose(update(ts, moved, w)[1]["target_mean"], out[1]["target_mean"])
