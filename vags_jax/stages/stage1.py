"""Training stages as pure functions (paper section 3.2).

Stage 1 trains GDNet alone in B parallel worlds of ``stage1.min_objects..max_objects`` objects.
One *iteration* is, for every world at once:

  1. GDNet (eval mode) on the global heightmaps -> Q (B, R, H, W) (with
     ``net.forward_needed_only`` only for the worlds that will take the greedy action);
  2. DAES picks an action (B, 3) [rotation, row, col] (``vags_jax.rl.exploration``);
  3. the grasp is simulated (``VagsEnv.step_grasp_or_reset``); reward = 1 on success else 0.
     Worlds whose round ended in the previous iteration (clear, attempt budget used, or a
     physics error) do not grasp this time: they get a new scene with a random object count,
     which settles in the same physics loop as the other worlds' grasps (so a reset does not
     stall the batch); then every world is rendered once;
  4. the grasping worlds' transitions go into prioritized replay (the resetting worlds add
     none); the last transition of a round is terminal (no bootstrap: a cleared table has no
     future, and the world's next view will be another scene).  With ``stage1.bootstrap =
     "actor"`` a transition stores no next state: it waits in replay, never sampled, until the
     next iteration's step 1 gives it the largest Q of the world's next state as its bootstrap
     value (``replay.fill_pending_values``; clipped to [0, 1 / (1 - gamma)] with
     ``stage1.bootstrap_clip``), and the updates make no pass over next states.  With
     ``"actor_argmax"`` a transition keeps its next state and waits for the next iteration's
     greedy action there (``replay.fill_pending_actions``); the updates' target is the target
     network's value at that action, a pass over one rotation of each next state instead of all;
  5. ``updates_per_iteration`` DQN updates from replay (once it holds ``learning_starts``).

Everything is one ``lax.scan`` over iterations inside one jit: no host round trip per step.
``Stage1.run(state, n)`` advances n iterations and returns per-iteration metrics, so a caller can
log and checkpoint between chunks; ``vags_jax.stages.pipeline`` chains it with the other stages.  Running the same chunks from a restored ``Stage1State`` gives
bit-identical results to an uninterrupted run.
"""
from __future__ import annotations

from typing import Optional

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from vags_jax import batching
from vags_jax.rl import dqn, exploration, replay
from vags_jax.config import Config
from vags_jax.parallel import collectives
from vags_jax.env import EnvState, VagsEnv
from vags_jax.nets import init_qnet, initial_variables, make_qnet


@struct.dataclass
class Stage1State:
    """Everything stage 1 carries from one iteration to the next (a checkpointable pytree).

    env: B worlds (``EnvState``); learner: GDNet online/target variables + optimizer state;
    replay: prioritized replay of ``GraspTransition`` (``ValuedGraspTransition`` with
    ``stage1.bootstrap = "actor"``, ``ArgmaxGraspTransition`` with ``"actor_argmax"``, the last
    iteration's items still waiting for their values or actions);
    key: (2,) uint32; iteration: () int32; attempts: () int32, grasp attempts made so far (all
    worlds).  (Which worlds start a new
    round in the next iteration follows from ``env``: ``round_over`` or a physics error.)
    """

    env: EnvState
    learner: dqn.TrainState
    replay: replay.ReplayState
    key: jax.Array
    iteration: jax.Array
    attempts: jax.Array


# Per-iteration metrics returned by Stage1.run, each of shape (n,).  q_max and q_executed are
# means over the worlds whose Q maps were computed (``Stage1.act``'s ``valued``).
METRICS = (
    "success_rate", "explored", "epsilon", "loss", "td_abs", "q_max", "q_executed",
    "rounds_ended", "rounds_cleared", "objects_on_table", "physics_errors", "buffer_overflow",
    "replay_size", "updates", "attempts", "attempts_total", "worlds_resetting",
)


# The parts of a Stage1State that are per device in data-parallel training (each device's worlds
# and replay shard); the others (learner, key, counters) are replicated.
PER_DEVICE = ("env", "replay")


class Stage1:
    """GDNet training in batched worlds.  Build once per config; ``run`` is compiled per n.

    ``axis_name`` (data parallel, ``vags_jax.stages.data_parallel``): this object is one
    device's share, run under ``jax.shard_map``: ``cfg`` is the per-device config (its worlds,
    replay capacity and batch), worlds draw from per-device key streams, gradients and BatchNorm
    statistics are averaged over the axis and the metrics are totals / means over all devices.
    None (one device): no collective at all."""

    def __init__(self, cfg: Config, env: Optional[VagsEnv] = None, axis_name: Optional[str] = None):
        self.cfg = cfg
        self.axis_name = axis_name
        self.env = env if env is not None else VagsEnv(cfg)
        self.net = make_qnet(cfg.net, "gdnet", axis_name)
        self.actor_bootstrap = cfg.stage1.bootstrap == "actor"
        self.actor_argmax = cfg.stage1.bootstrap == "actor_argmax"
        self.pending = self.actor_bootstrap or self.actor_argmax  # items wait for the next iteration's pass
        # The largest discounted return of 0/1 rewards: the stored values' ceiling when clipped.
        self.value_cap = 1.0 / (1.0 - cfg.dqn.gamma) if cfg.stage1.bootstrap_clip else None
        self.update = dqn.make_update_step(self._apply, cfg.dqn, executed_rotation_only=True, axis_name=axis_name,
                                           n_rotations=cfg.net.n_rotations)
        self._run_jit = jax.jit(self._run_impl, static_argnums=1)

    def _apply(self, variables, color, height, train, mutable=False, rotations=None):
        return self.net.apply(variables, color, height, train, rotations=rotations, mutable=mutable)

    def bootstrap_values(self, q: jax.Array) -> jax.Array:
        """Q maps (B, R, H, W) -> (B,) the values the actor stores for its worlds' states: the
        largest Q, clipped to [0, 1 / (1 - gamma)] with ``stage1.bootstrap_clip``."""
        v = q.reshape(q.shape[0], -1).max(axis=1)
        return v if self.value_cap is None else jnp.clip(v, 0.0, self.value_cap)

    def act(self, learner: dqn.TrainState, s: EnvState, grasped: jax.Array, key: jax.Array, eps):
        """Steps 1-2 of an iteration: GDNet's Q maps and DAES's actions for the worlds of ``s``
        (``grasped`` (B,) bool: the worlds that grasp, not reset, this iteration).  Returns
        ``action (B, 3) int32``, ``explored (B,) bool``, ``q (B, R, H, W)`` and ``valued (B,)
        bool``, the worlds whose Q maps were computed (the others' are zeros)."""
        cfg = self.cfg
        random_action, explored = exploration.draw_grasp_exploration(key, cfg.net.n_rotations, s.height, eps,
                                                                     cfg.exploration)
        valued = self._valued(grasped, explored)
        q = self._q_maps({"params": learner.params, "batch_stats": learner.batch_stats}, s, valued)
        action = jnp.where(explored[:, None], random_action, exploration.greedy_grasp(q))
        return action, explored, q, valued

    def _valued(self, grasped: jax.Array, explored: jax.Array) -> jax.Array:
        """(B,) bool: the worlds whose Q maps this iteration uses.  Every world unless
        ``net.forward_needed_only``; with it, the grasping worlds that take the greedy action
        (with ``bootstrap = "actor"`` or ``"actor_argmax"`` every grasping world: its largest Q
        or its argmax is stored)."""
        if not self.cfg.net.forward_needed_only:
            return jnp.ones_like(grasped)
        return grasped if self.pending else grasped & ~explored

    def _q_maps(self, variables, s: EnvState, valued: jax.Array) -> jax.Array:
        """GDNet (eval mode) on the worlds' heightmaps -> (B, R, H, W): one pass over every world,
        or with ``net.forward_needed_only`` over the ``valued`` worlds only, in groups of
        ``net.forward_batch`` (zeros for the others)."""
        apply = lambda c, h: self._apply(variables, c, h, False)  # noqa: E731
        if not self.cfg.net.forward_needed_only:
            return apply(s.color, s.height)
        return batching.map_in_groups_where(apply, (s.color, s.height), self.cfg.net.forward_batch, valued)

    def _n_objects(self, key: jax.Array, n_worlds: int) -> jax.Array:
        s = self.cfg.stage1
        return jax.random.randint(key, (n_worlds,), s.min_objects, s.max_objects + 1, jnp.int32)

    @staticmethod
    def init_keys(key: jax.Array):
        """A stage's key -> (k_net, k_n, k_env, k_loop), each (2,) raw uint32."""
        key = jnp.asarray(key)
        if jnp.issubdtype(key.dtype, jax.dtypes.prng_key):
            key = jax.random.key_data(key)
        return tuple(jax.random.split(key, 4))

    def new_learner(self, k_net: jax.Array) -> dqn.TrainState:
        """A freshly initialised GDNet learner (``net.init`` weights when the config names them)."""
        H = self.cfg.workspace.heightmap_px
        return dqn.create_train_state(initial_variables(k_net, self.net, self.cfg.net, H, H), self.cfg.dqn)

    def empty_replay(self, env_state: EnvState) -> replay.ReplayState:
        """An empty replay of ``replay.capacity`` grasp transitions shaped as ``env_state``'s maps."""
        return replay.init(self.cfg.replay.capacity,
                           example_transition(self.cfg, env_state.color[0], env_state.height[0]))

    def transitions(self, s: EnvState, action: jax.Array, reward: jax.Array, s2: EnvState, done: jax.Array):
        """The B worlds' transitions from ``s`` to ``s2`` in this stage's replay type: action (B, 3),
        reward and done (B,).  With ``bootstrap = "actor"`` their values are still to come, with
        ``"actor_argmax"`` their next states' greedy actions."""
        if self.actor_bootstrap:
            return replay.make_valued_transition(s.color, s.height, action, reward, done)
        if self.actor_argmax:
            return replay.make_argmax_transition(s.color, s.height, action, reward, s2.color, s2.height, done)
        return replay.make_grasp_transition(s.color, s.height, action, reward, s2.color, s2.height, done)

    def init_worlds(self, k_n: jax.Array, k_env: jax.Array):
        """Pure and jittable (per device under ``jax.shard_map``): ``stage1.n_worlds`` new scenes
        drawn from this device's streams of k_n / k_env (``collectives.device_key``) and an
        empty replay -> (EnvState, ReplayState)."""
        ax = self.axis_name
        n_objects = self._n_objects(collectives.device_key(k_n, ax), self.cfg.stage1.n_worlds)
        env_state = self.env.step_reset(collectives.device_key(k_env, ax), n_objects)
        return env_state, self.empty_replay(env_state)

    def init(self, key: jax.Array, learner: Optional[dqn.TrainState] = None) -> Stage1State:
        """Fresh worlds, replay and (unless given) a freshly initialised GDNet learner.  Returns
        without waiting for the reset (the first chunk's program can compile meanwhile, beside
        Warp's first kernel compiles on impl "warp").  Its worlds' buffer-overflow flags stay set
        into the first iteration's metrics (``buffer_overflow``; but for a world whose round ends
        at that attempt and resets), which ``driver.run_chunks`` warns about."""
        k_net, k_n, k_env, k_loop = self.init_keys(key)
        if learner is None:
            learner = self.new_learner(k_net)
        env_state = self.env.reset(k_env, np.asarray(self._n_objects(k_n, self.cfg.stage1.n_worlds)),
                                   check_buffers=False)
        return Stage1State(env=env_state, learner=learner, replay=self.empty_replay(env_state), key=k_loop,
                           iteration=jnp.zeros((), jnp.int32), attempts=jnp.zeros((), jnp.int32))

    # ------------------------------------------------------------------ one iteration

    def _learn(self, learner, buffer, key):
        """updates_per_iteration DQN updates (skipped until replay holds learning_starts)."""
        s = self.cfg.stage1
        return dqn.learn_from_replay(self.update, learner, buffer, key, self.cfg, s.updates_per_iteration,
                                     s.learning_starts, self.axis_name, count_pending=self.pending)

    def _iteration(self, state: Stage1State, _):
        cfg, env = self.cfg, self.env
        key, k_act, k_grasp, k_n, k_reset, k_learn = jax.random.split(state.key, 6)
        ax = self.axis_name  # None on one device: every collective below is the identity
        k_act, k_grasp, k_n, k_reset, k_learn = (collectives.device_key(k, ax)
                                                 for k in (k_act, k_grasp, k_n, k_reset, k_learn))
        s = state.env
        eps = exploration.epsilon(state.iteration, cfg.exploration)
        resetting = env.round_over(s) | s.sim.error  # rounds that ended last iteration
        grasped = ~resetting
        action, explored, q, valued = self.act(state.learner, s, grasped, k_act, eps)
        q_exec = dqn.q_at_action(q, action)
        buffer = state.replay
        if self.actor_bootstrap:  # last iteration's transitions get their next state's value
            buffer = replay.fill_pending_values(buffer, self.bootstrap_values(q))
        if self.actor_argmax:  # ... or their next state's greedy action
            buffer = replay.fill_pending_actions(buffer, exploration.greedy_grasp(q))

        noise_key = k_grasp if cfg.camera.noise.enabled else None
        # Grasps of the playing worlds and new scenes of the worlds whose round ended, in one
        # physics loop, then ONE render of all worlds.
        s2, result = env.step_grasp_or_reset(s, action[:, 1:], action[:, 0], resetting, k_reset,
                                             self._n_objects(k_n, s.n_worlds), observe=False)
        s2 = env.with_observation(s2, noise_key)
        reward = result.success.astype(jnp.float32)
        cleared = grasped & (env.n_remaining(s2) == 0)
        over = env.round_over(s2) | s2.sim.error
        buffer = replay.add(buffer, self.transitions(s, action, reward, s2, over), mask=grasped,
                            pending=self.pending)
        learner, buffer, (loss, td_abs), n_updates = self._learn(state.learner, buffer, k_learn)

        # Metrics over all worlds: totals and means over the devices (each holds as many worlds).
        total = lambda x: collectives.total(x, ax)  # noqa: E731
        mean = lambda x: collectives.mean(x, ax)  # noqa: E731
        n_grasped = total(grasped.sum())
        n_valued = jnp.maximum(total(valued.sum()), 1)
        attempts = state.attempts + n_grasped
        metrics = {
            "success_rate": total(reward.sum()) / jnp.maximum(n_grasped, 1),
            "explored": total((explored & grasped).sum()) / jnp.maximum(n_grasped, 1),
            "epsilon": jnp.asarray(eps, jnp.float32),
            "loss": loss,
            "td_abs": td_abs,
            "q_max": total(jnp.where(valued, q.reshape(q.shape[0], -1).max(axis=1), 0.0).sum()) / n_valued,
            "q_executed": total(jnp.where(valued, q_exec, 0.0).sum()) / n_valued,
            "rounds_ended": total((over & grasped).sum()),
            "rounds_cleared": total(cleared.sum()),
            "objects_on_table": mean(env.n_remaining(s2).mean()),
            "physics_errors": total(s2.sim.error.sum()),
            "buffer_overflow": total(s2.sim.overflow.sum()),
            "replay_size": total(buffer.size),
            "updates": n_updates,
            "attempts": n_grasped,
            "attempts_total": attempts,
            "worlds_resetting": total(resetting.sum()),
        }
        metrics = {k: jnp.asarray(v, jnp.float32) for k, v in metrics.items()}
        new_state = Stage1State(env=s2, learner=learner, replay=buffer, key=key,
                                iteration=state.iteration + 1, attempts=attempts)
        return new_state, metrics

    def _run_impl(self, state: Stage1State, n: int):
        return jax.lax.scan(self._iteration, state, None, length=n)

    # ------------------------------------------------------------------ public

    def run(self, state: Stage1State, n: int):
        """Advance ``n`` iterations -> (state, metrics dict of (n,) float32 arrays)."""
        if not isinstance(n, int) or n < 1:
            raise ValueError(f"run: n must be a positive int, got {n!r}")
        self.env.prepare(state.env.n_worlds)  # caches built outside the trace
        return self._run_jit(state, n)

    def compile_chunk(self, state: Stage1State, n: int) -> None:
        """Compiles (never runs) the program ``run(state, n)`` runs: into the compile cache, for a
        later process (``stages.precompile``)."""
        self.env.prepare(state.env.n_worlds)
        self._run_jit.lower(state, n).compile()


def checkpoint_layout(cfg: Config) -> dict:
    """Shapes and dtypes (pytrees of ``jax.ShapeDtypeStruct``) of the ``Stage1State`` parts
    that follow from the config alone: ``learner``, ``replay``, ``key``, ``iteration`` and
    ``attempts`` (``env`` needs the simulator).  Traced with ``jax.eval_shape``: nothing is
    compiled or allocated, so a checkpoint can be checked against a config before any
    compiling (train.py --resume).  With ``parallel.devices`` = N > 1 the replay is N shards,
    stacked on a leading axis (``vags_jax.stages.data_parallel``)."""
    H = cfg.workspace.heightmap_px
    net = make_qnet(cfg.net, "gdnet")
    learner = jax.eval_shape(lambda k: dqn.create_train_state(init_qnet(k, net, H, H), cfg.dqn),
                             jax.random.PRNGKey(0))
    d = cfg.parallel.devices  # data parallel: one replay shard per device, stacked

    def buffer():
        color, height = jnp.zeros((H, H, 3), jnp.uint8), jnp.zeros((H, H), jnp.float32)
        return replay.init(cfg.replay.capacity // d, example_transition(cfg, color, height))

    buffers = jax.eval_shape(buffer)
    if d > 1:
        buffers = jax.tree.map(lambda s: jax.ShapeDtypeStruct((d,) + s.shape, s.dtype), buffers)
    scalar = jax.ShapeDtypeStruct((), jnp.int32)
    return {"learner": learner, "replay": buffers,
            "key": jax.eval_shape(lambda: jax.random.split(jax.random.PRNGKey(0))[0]),
            "iteration": scalar, "attempts": scalar}


def example_transition(cfg: Config, color: jax.Array, height: jax.Array):
    """One stage-1 replay item (no batch dim) for ``color`` (H, W, 3) and ``height`` (H, W): a
    ``GraspTransition``, or with ``stage1.bootstrap = "actor"`` a ``ValuedGraspTransition``, with
    ``"actor_argmax"`` an ``ArgmaxGraspTransition``."""
    action = jnp.zeros((3,), jnp.int32)
    if cfg.stage1.bootstrap == "actor":
        return jax.tree.map(lambda x: x[0], replay.make_valued_transition(
            color[None], height[None], action[None], jnp.zeros((1,)), jnp.zeros((1,), bool)))
    if cfg.stage1.bootstrap == "actor_argmax":
        return jax.tree.map(lambda x: x[0], replay.make_argmax_transition(
            color[None], height[None], action[None], jnp.zeros((1,)), color[None], height[None],
            jnp.zeros((1,), bool)))
    return replay.make_grasp_transition(color, height, action, 0.0, color, height, False)
