"""Q-learning for GDNet and VANet: train state, optimizer, TD target, Huber loss, update step.

Shapes: GDNet gives Q of shape (b, R, H, W) and actions (b, 3) = [rotation, row, col];
VANet gives Q of shape (b, H, W) and actions (b, 2) = [row, col].  Every function below
accepts either; the rank of ``q`` decides.

Network contract (vags_jax.nets): ``apply_fn(variables, color (b,H,W,3) uint8,
height (b,H,W) float32, train)`` with ``train`` passed positionally; with ``train=True`` it is
called with ``mutable=['batch_stats']`` and returns ``(q, {'batch_stats': ...})``.
"""
from __future__ import annotations

from typing import Any, Callable, Optional

import flax.struct
import jax
import jax.numpy as jnp
import optax

from vags_jax.config import DQN
from vags_jax.parallel import collectives
from vags_jax.rl import replay

PyTree = Any


@flax.struct.dataclass
class TrainState:
    """Online and target variables plus optimizer state; a plain pytree (orbax-checkpointable).

    The optimizer itself is not stored: rebuild it with :func:`make_optimizer` from the config.
    """

    step: jax.Array  # () int32, gradient steps taken
    params: PyTree
    batch_stats: PyTree
    target_params: PyTree
    target_batch_stats: PyTree
    opt_state: optax.OptState


def make_optimizer(cfg: DQN) -> optax.GradientTransformation:
    """SGD with momentum (paper) or Adam.  ``weight_decay`` is an L2 penalty added to the
    gradient before momentum / Adam moments -- PyTorch's ``SGD(weight_decay=...)`` and
    ``Adam(weight_decay=...)`` semantics, not decoupled (AdamW) decay.  It applies to every
    parameter, BatchNorm scales and biases included, as in PyTorch."""
    if cfg.optimizer == "sgd":
        opt = optax.sgd(cfg.learning_rate, momentum=cfg.momentum if cfg.momentum > 0 else None)
    elif cfg.optimizer == "adam":
        opt = optax.adam(cfg.learning_rate)
    else:  # DQN.__post_init__ already rejects this
        raise ValueError(f"DQN.optimizer must be 'sgd' or 'adam', got {cfg.optimizer!r}")
    if cfg.weight_decay > 0:
        return optax.chain(optax.add_decayed_weights(cfg.weight_decay), opt)
    return opt


def create_train_state(variables: PyTree, cfg: DQN) -> TrainState:
    """From ``module.init(...)`` variables ({'params', optional 'batch_stats'}); the target
    network starts as a copy of the online one."""
    params = variables["params"]
    batch_stats = variables.get("batch_stats", {})
    copy = lambda t: jax.tree.map(jnp.array, t)  # noqa: E731  (distinct buffers)
    return TrainState(
        step=jnp.zeros((), jnp.int32),
        params=params,
        batch_stats=batch_stats,
        target_params=copy(params),
        target_batch_stats=copy(batch_stats),
        opt_state=make_optimizer(cfg).init(params),
    )


# ----------------------------------------------------------------------------- targets and loss


def _flat_max(q: jax.Array) -> jax.Array:
    return jnp.max(q.reshape(q.shape[0], -1), axis=-1)


def td_target(reward: jax.Array, done: jax.Array, next_q: jax.Array, gamma: float) -> jax.Array:
    """y = r + gamma * max_a Q_target(s', a), with no bootstrap where ``done``.

    reward (b,), done (b,) bool, next_q (b, R, H, W) or (b, H, W) -> y (b,) float32 (no gradient)."""
    boot = jnp.where(done, 0.0, _flat_max(next_q.astype(jnp.float32)))
    return jax.lax.stop_gradient(reward.astype(jnp.float32) + gamma * boot)


def double_q_td_target(reward, done, next_q_target, next_q_online, gamma: float) -> jax.Array:
    """Double DQN: y = r + gamma * Q_target(s', argmax_a Q_online(s', a)); shapes as td_target."""
    b = next_q_online.shape[0]
    a = jnp.argmax(next_q_online.reshape(b, -1), axis=-1)
    v = jnp.take_along_axis(next_q_target.reshape(b, -1).astype(jnp.float32), a[:, None], axis=-1)[:, 0]
    return jax.lax.stop_gradient(reward.astype(jnp.float32) + gamma * jnp.where(done, 0.0, v))


def q_at_action(q: jax.Array, action: jax.Array) -> jax.Array:
    """q (b, R, H, W) with action (b, 3) [rot, row, col], or q (b, H, W) with action (b, 2)
    [row, col] -> (b,) the value at the executed action."""
    b = q.shape[0]
    if action.shape[-1] != q.ndim - 1:
        raise ValueError(f"action of shape {action.shape} does not index q of shape {q.shape}")
    return q[(jnp.arange(b),) + tuple(action[:, i] for i in range(action.shape[-1]))]


def huber(x: jax.Array, delta: float) -> jax.Array:
    """Elementwise Huber: 0.5 x^2 for |x| <= delta, delta (|x| - delta / 2) beyond."""
    ax = jnp.abs(x)
    quad = jnp.minimum(ax, delta)
    return 0.5 * quad**2 + delta * (ax - quad)


def huber_loss_at_action(q: jax.Array, action: jax.Array, y: jax.Array, weights: jax.Array,
                         delta: float, symmetric: bool = False):
    """Huber loss on the executed pixel only (the gradient w.r.t. ``q`` is zero elsewhere).

    q (b, R, H, W) / (b, H, W); action (b, 3) / (b, 2); y (b,); weights (b,) importance weights.
    Returns ``(loss, td_error)``: loss = mean_b(weights * huber(y - q[action])) (scalar) and
    td_error = y - q[action] (b,), for the replay priorities.

    ``symmetric`` (GDNet only, VPG's trick): the same label is also applied at rotation
    ``(rot + R/2) % R`` -- the same physical parallel-jaw grasp -- adding a second Huber term.
    """
    q = q.astype(jnp.float32)
    td = y - q_at_action(q, action)
    per_item = huber(td, delta)
    if symmetric:
        if q.ndim != 4 or q.shape[1] % 2:
            raise ValueError(f"symmetric labels need q (b, R, H, W) with even R, got {q.shape}")
        r = q.shape[1]
        mirrored = action.at[:, 0].set((action[:, 0] + r // 2) % r)
        per_item = per_item + huber(y - q_at_action(q, mirrored), delta)
    loss = jnp.mean(weights.astype(jnp.float32) * per_item)
    return loss, td


# ----------------------------------------------------------------------------- update step


# Long (one reason): target, loss and optimizer step share one closure over the config and apply_fn.
def make_update_step(apply_fn: Callable, cfg: DQN, executed_rotation_only: bool = False,
                     axis_name: Optional[str] = None, n_rotations: Optional[int] = None) -> Callable:
    """Build ``update(train_state, batch, weights) -> (train_state, metrics, td_errors (b,))``.

    ``executed_rotation_only`` (GDNet): the online network is evaluated only at each sample's
    executed rotation (and its mirror with ``cfg.symmetric_grasp_label``) through
    ``apply_fn(..., rotations=(b, K))``, at 1/R (or 2/R) of the full (b, R, H, W) cost.  For a
    network without batch statistics the loss and gradients are exactly those of the full
    evaluation; with BatchNorm in train mode the statistics come from the b executed rotations
    instead of all b * R rotated images (VPG likewise back-propagates the executed rotation
    only).  The target still takes the max over every rotation of the next state.

    ``batch`` is a sampled transition pytree with fields color (b,H,W,3) uint8, height
    (b,H,W) (float16/bfloat16/float32), action (b,3) or (b,2) int32, reward (b,), next_color,
    next_height, done (b,) bool (e.g. :class:`vags_jax.rl.replay.GraspTransition`); ``weights``
    (b,) are the importance weights.  The target uses the target network in eval mode (and the
    online network in eval mode for the argmax when ``cfg.double_q``); the loss uses the online
    network in train mode, whose BatchNorm statistics are updated.  After the optimizer step,
    the target network (params and batch_stats) is copied from the online one whenever the new
    step count is a multiple of ``cfg.target_update_period``.  Jittable.

    A batch of :class:`vags_jax.rl.replay.ValuedGraspTransition` carries its bootstrap value:
    y = r + gamma * next_value (none where ``done``), with no pass over the next state (VPG
    stores its labels so).  A batch of :class:`vags_jax.rl.replay.ArgmaxGraspTransition`
    carries the action the actor chose greedily on the next state: y = r + gamma *
    Q_target(s', next_action) (Double DQN's target with the actor's argmax), from the target
    network's pass at that one rotation (``apply_fn(..., rotations=(b, 1))``).  ``n_rotations``
    (GDNet's R) is needed with either for ``cfg.symmetric_grasp_label``, whose mirror rotation
    otherwise comes from the full target pass.

    ``axis_name`` (data-parallel training, under ``jax.shard_map``): ``batch`` is this device's
    share of the batch; the gradients and the metrics are averaged over the axis before the
    optimizer step, so that parameters and optimizer state stay identical on every device.
    ``apply_fn``'s network must average its BatchNorm statistics over the same axis
    (``make_qnet(..., axis_name=)``); the update then equals the one-device update of the whole
    batch (up to float rounding).  ``td_errors`` stay per device (this device's replay shard).
    """
    tx = make_optimizer(cfg)

    def update(ts: TrainState, batch, weights: jax.Array):
        color, height = batch.color, batch.height.astype(jnp.float32)

        target_vars = {"params": ts.target_params, "batch_stats": ts.target_batch_stats}
        r_all = n_rotations
        if cfg.gamma == 0:  # y = r, a success estimate: no pass over the next state
            y = jax.lax.stop_gradient(batch.reward.astype(jnp.float32))
        elif isinstance(batch, replay.ValuedGraspTransition):  # the value the actor's pass stored
            v = jnp.where(batch.done, 0.0, batch.next_value.astype(jnp.float32))
            y = jax.lax.stop_gradient(batch.reward.astype(jnp.float32) + cfg.gamma * v)
        elif isinstance(batch, replay.ArgmaxGraspTransition):  # the target's value at the actor's argmax
            a = batch.next_action
            next_q_t = apply_fn(target_vars, batch.next_color, batch.next_height.astype(jnp.float32), False,
                                rotations=a[:, :1])  # (b, 1, H, W): one rotation of each next state
            v = jnp.where(batch.done, 0.0, q_at_action(next_q_t.astype(jnp.float32), a.at[:, 0].set(0)))
            y = jax.lax.stop_gradient(batch.reward.astype(jnp.float32) + cfg.gamma * v)
        else:
            next_color, next_height = batch.next_color, batch.next_height.astype(jnp.float32)
            next_q_t = apply_fn(target_vars, next_color, next_height, False)
            r_all = next_q_t.shape[1] if next_q_t.ndim == 4 else None
            if cfg.double_q:
                online_vars = {"params": ts.params, "batch_stats": ts.batch_stats}
                next_q_o = apply_fn(online_vars, next_color, next_height, False)
                y = double_q_td_target(batch.reward, batch.done, next_q_t, next_q_o, cfg.gamma)
            else:
                y = td_target(batch.reward, batch.done, next_q_t, cfg.gamma)
        sub_rot = executed_rotation_only and batch.action.shape[-1] == 3
        if sub_rot and cfg.symmetric_grasp_label and r_all is None:
            raise ValueError("symmetric grasp labels need gamma > 0 or n_rotations (the rotation count comes "
                             "from the target pass)")

        def loss_fn(params):
            online = {"params": params, "batch_stats": ts.batch_stats}
            if sub_rot:
                rot = batch.action[:, :1]
                rots = jnp.concatenate([rot, (rot + r_all // 2) % r_all], 1) if cfg.symmetric_grasp_label else rot
                q, new_vars = apply_fn(online, color, height, True, mutable=["batch_stats"], rotations=rots)
                local = batch.action.at[:, 0].set(0)  # q[:, 0] is the executed rotation
                loss, td = huber_loss_at_action(q, local, y, weights, cfg.huber_delta, False)
                if cfg.symmetric_grasp_label:
                    mirror = huber(y - q_at_action(q.astype(jnp.float32), batch.action.at[:, 0].set(1)), cfg.huber_delta)
                    loss = loss + jnp.mean(weights.astype(jnp.float32) * mirror)
                return loss, (td, new_vars.get("batch_stats", ts.batch_stats), q, local)
            q, new_vars = apply_fn(online, color, height, True, mutable=["batch_stats"])
            loss, td = huber_loss_at_action(q, batch.action, y, weights, cfg.huber_delta,
                                            cfg.symmetric_grasp_label)
            return loss, (td, new_vars.get("batch_stats", ts.batch_stats), q, batch.action)

        (loss, (td, batch_stats, q, q_action)), grads = jax.value_and_grad(loss_fn, has_aux=True)(ts.params)
        grads = collectives.mean(grads, axis_name)  # every device's share of the batch
        updates, opt_state = tx.update(grads, ts.opt_state, ts.params)
        params = optax.apply_updates(ts.params, updates)
        step = ts.step + 1
        sync = (step % cfg.target_update_period) == 0
        pick = lambda new, old: jax.tree.map(lambda n, o: jnp.where(sync, n, o), new, old)  # noqa: E731
        new_ts = TrainState(
            step=step,
            params=params,
            batch_stats=batch_stats,
            target_params=pick(params, ts.target_params),
            target_batch_stats=pick(batch_stats, ts.target_batch_stats),
            opt_state=opt_state,
        )
        means = collectives.mean({
            "loss": loss,
            "td_abs_mean": jnp.mean(jnp.abs(td)),
            "q_taken_mean": jnp.mean(q_at_action(q.astype(jnp.float32), q_action)),
            "q_max_mean": jnp.mean(_flat_max(q.astype(jnp.float32))),
            "target_mean": jnp.mean(y),
        }, axis_name)
        metrics = {**means, "grad_norm": optax.tree.norm(grads), "target_synced": sync}
        return new_ts, metrics, td

    return update


def learn_from_replay(update: Callable, learner: TrainState, buffer, key: jax.Array, cfg, n_updates: int,
                      learning_starts: int, axis_name: Optional[str] = None, count_pending: bool = False):
    """``n_updates`` updates of one network from its prioritized replay (``vags_jax.rl.replay``),
    none until the buffer holds ``learning_starts`` transitions; ``update`` from
    ``make_update_step``, ``cfg`` the whole Config (its ``dqn`` and ``replay`` sections).
    Returns (learner, buffer, (mean loss, mean |td|) (2,), updates done ()).

    ``axis_name`` (data parallel): ``buffer`` is this device's replay shard and ``cfg`` the
    per-device config (its ``dqn.batch_size`` this device's share); updates start once every
    shard holds ``learning_starts``, so that all devices update together; ``key`` should
    differ per device (``collectives.device_key``).  ``count_pending``: a buffer with pending
    items (``replay.add(..., pending=True)``) counts only the ones ``sample`` can draw."""
    held = replay.sampleable(buffer) if count_pending else buffer.size
    ready = collectives.smallest(held, axis_name) >= max(learning_starts, 1)

    def one(carry, k):
        def do(args):
            learner, buffer = args
            idx, batch, w = replay.sample(buffer, k, cfg.dqn.batch_size, cfg.replay.alpha, cfg.replay.beta,
                                          axis_name)
            learner, m, td = update(learner, batch, w)
            buffer = replay.update_priorities(buffer, idx, td, cfg.replay.priority_eps)
            return (learner, buffer), jnp.stack([m["loss"], m["td_abs_mean"]])

        return jax.lax.cond(ready, do, lambda a: (a, jnp.zeros((2,), jnp.float32)), carry)

    (learner, buffer), stats = jax.lax.scan(one, (learner, buffer), jax.random.split(key, n_updates))
    return learner, buffer, stats.mean(axis=0), jnp.where(ready, n_updates, 0)
