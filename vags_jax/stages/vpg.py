"""VPG's training stage (``train.py --stage vpg``): push and grasp Q-networks trained together
in B parallel worlds of ``vpg.min_objects..max_objects`` objects, and its place in a run
directory (``RUN/vpg/``).

One *iteration*, for every world at once (one ``lax.scan`` step, as stage 1's):

  1. ``VPGNet`` (eval mode) on the global heightmaps -> Q (B, 2R, H, W), push and grasp maps;
  2. VPG's exploration picks the primitive (``policies.vpg.select``) and the argmax within it;
  3. the push or grasp is simulated (``env.push.step_with_pushes``); worlds whose round ended
     (table clear, ``2 * objects + vpg.max_attempts_extra`` actions, or a physics error) get a
     new scene instead, settling in the same physics loop; then every world is rendered once;
  4. reward (``policies.vpg.reward``): 1 for a successful grasp, 0.5 for a push that changed
     the height map (``scene_changed``); no future term when nothing changed and no grasp
     succeeded, or at the end of a round (``no_future``);
  5. the acting worlds' transitions go into prioritized replay and ``vpg.updates_per_iteration``
     DQN updates follow (``rl.dqn``: y = r + gamma max over both primitives' maps of the next
     view, Huber loss at the executed channel and pixel).

``VpgStage.run(state, n)`` advances n iterations; ``stages.driver.main_vpg`` runs it chunk by
chunk with checkpoints in ``RUN/vpg/checkpoints`` (resumable bit for bit, as stage 1), its
config in ``RUN/vpg/config.json`` and metrics in ``RUN/vpg/metrics.jsonl``.  ``load_vpg`` reads
the trained networks for ``eval.py --policy vpg``.
"""
from __future__ import annotations

import os
from typing import Optional

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from vags_jax import batching
from vags_jax.config import Config, check_vpg_fits
from vags_jax.env import EnvState, VagsEnv
from vags_jax.env.push import step_with_pushes
from vags_jax.nets import init_qnet
from vags_jax.nets.vpg import make_vpg_net
from vags_jax.policies import vpg
from vags_jax.rl import dqn, exploration, replay
from vags_jax.stages import checkpoint

VPG_DIR = "vpg"
SEED_SALT = 0x7667  # folded into PRNGKey(cfg.seed): VPG's stream, apart from the pipeline's

# Per-iteration metrics returned by VpgStage.run, each of shape (n,).
METRICS = (
    "success_rate", "push_share", "push_changed", "explored", "epsilon", "loss", "td_abs", "q_max",
    "q_executed", "reward", "rounds_ended", "rounds_cleared", "objects_on_table", "physics_errors",
    "buffer_overflow", "replay_size", "updates", "attempts", "attempts_total", "worlds_resetting",
)


@struct.dataclass
class VpgState:
    """VPG's carry (a checkpointable pytree).  env: B worlds; pushes: (B,) int32 pushes in each
    world's current round (``env.attempts`` counts its grasps); learner: VPGNet online/target
    variables + optimizer state; replay of ``GraspTransition`` with [channel, row, col]
    actions; key (2,); iteration () int32; attempts () int32 actions (pushes and grasps) so far."""

    env: EnvState
    pushes: jax.Array
    learner: dqn.TrainState
    replay: replay.ReplayState
    key: jax.Array
    iteration: jax.Array
    attempts: jax.Array


def vpg_dir(run_dir: str) -> str:
    return os.path.join(run_dir, VPG_DIR)


def stage_key(cfg: Config) -> jax.Array:
    return jax.random.fold_in(jax.random.PRNGKey(cfg.seed), SEED_SALT)


def check_config(cfg: Config) -> None:
    """What VPG's stage needs of a config; ValueError saying what to change."""
    check_vpg_fits(cfg)
    if cfg.dqn.symmetric_grasp_label:
        raise ValueError("dqn.symmetric_grasp_label does not apply to vpg (its channels mix pushes and "
                         "grasps): set dqn.symmetric_grasp_label=false")
    if cfg.grasp.half_turn:
        raise ValueError("vpg pushes in all n_rotations directions of a whole turn: set grasp.half_turn=false "
                         "and net.half_turn=false for --stage vpg")
    if cfg.net.init is not None:
        raise ValueError("net.init (ImageNet DenseNet-121 weights) is not loaded into VPG's four trunks: "
                         "set net.init=null for --stage vpg")


class VpgStage:
    """VPG training in batched worlds.  Build once per config; ``run`` is compiled per n."""

    donates = False

    def __init__(self, cfg: Config, env: Optional[VagsEnv] = None):
        check_config(cfg)
        self.cfg = cfg
        self.env = env if env is not None else VagsEnv(cfg)
        self.net = make_vpg_net(cfg.net)
        self.update = dqn.make_update_step(self._apply, cfg.dqn, executed_rotation_only=True)
        self._run_jit = jax.jit(self._run_impl, static_argnums=1)

    def _apply(self, variables, color, height, train, mutable=False, rotations=None):
        return self.net.apply(variables, color, height, train, rotations=rotations, mutable=mutable)

    def _n_objects(self, key: jax.Array, n_worlds: int) -> jax.Array:
        v = self.cfg.vpg
        return jax.random.randint(key, (n_worlds,), v.min_objects, v.max_objects + 1, jnp.int32)

    def round_over(self, s: EnvState, pushes: jax.Array) -> jax.Array:
        """(B,) bool: table clear, ``2 * objects + vpg.max_attempts_extra`` actions, or an error."""
        budget = self.env.max_attempts(s.sim.n_objects, self.cfg.vpg.max_attempts_extra)
        return (self.env.n_remaining(s) == 0) | (s.attempts + pushes >= budget) | s.sim.error

    def init(self, key: jax.Array) -> VpgState:
        """Fresh worlds, replay and VPGNet learner."""
        cfg = self.cfg
        k_net, k_n, k_env, k_loop = jax.random.split(jnp.asarray(key), 4)
        H = cfg.workspace.heightmap_px
        learner = dqn.create_train_state(init_qnet(k_net, self.net, H, H), cfg.dqn)
        env_state = self.env.reset(k_env, np.asarray(self._n_objects(k_n, cfg.vpg.n_worlds)))
        return VpgState(env=env_state, pushes=jnp.zeros((cfg.vpg.n_worlds,), jnp.int32), learner=learner,
                        replay=replay.init(cfg.replay.capacity, _example(env_state.color[0], env_state.height[0])),
                        key=k_loop, iteration=jnp.zeros((), jnp.int32), attempts=jnp.zeros((), jnp.int32))

    def _iteration(self, state: VpgState, _):
        cfg, env = self.cfg, self.env
        key, k_act, k_obs, k_n, k_reset, k_learn = jax.random.split(state.key, 6)
        s = state.env
        eps = exploration.epsilon(state.iteration, cfg.exploration)
        variables = {"params": state.learner.params, "batch_stats": state.learner.batch_stats}
        # (B, 2R, H, W), in world groups of net.forward_batch (inference memory, as stages 1-3)
        q = batching.map_in_groups(lambda c, h: self._apply(variables, c, h, False), (s.color, s.height),
                                   cfg.net.forward_batch)
        action, explored = vpg.select(k_act, q, eps)
        attempt = vpg.attempt_of(env, s, action)
        resetting = self.round_over(s, state.pushes)  # rounds that ended last iteration
        acting = ~resetting
        s2, gres, _ = step_with_pushes(env, s, attempt, observe=False,
                                       reset=(resetting, k_reset, self._n_objects(k_n, s.n_worlds)))
        s2 = env.with_observation(s2, k_obs if cfg.camera.noise.enabled else None)
        push = attempt.push & acting
        pushes = jnp.where(resetting, 0, state.pushes + push.astype(jnp.int32))
        changed = vpg.scene_changed(s.height, s2.height, cfg.vpg)
        success = gres.success & acting
        reward = vpg.reward(push, success, changed, cfg.vpg)
        over = self.round_over(s2, pushes)
        done = vpg.no_future(success, changed, over)
        buffer = replay.add(state.replay, replay.make_grasp_transition(
            s.color, s.height, action, reward, s2.color, s2.height, done), mask=acting)
        learner, buffer, (loss, td_abs), n_updates = dqn.learn_from_replay(
            self.update, state.learner, buffer, k_learn, cfg, cfg.vpg.updates_per_iteration, cfg.vpg.learning_starts)

        n_act, n_push = acting.sum(), push.sum()
        n_grasp = n_act - n_push
        attempts = state.attempts + n_act
        per = lambda x, n: x / jnp.maximum(n, 1)  # noqa: E731
        metrics = {
            "success_rate": per(success.sum(), n_grasp), "push_share": per(n_push, n_act),
            "push_changed": per((push & changed).sum(), n_push), "explored": per((explored & acting).sum(), n_act),
            "epsilon": eps, "loss": loss, "td_abs": td_abs, "q_max": q.reshape(q.shape[0], -1).max(axis=1).mean(),
            "q_executed": dqn.q_at_action(q, action).mean(), "reward": per(jnp.where(acting, reward, 0.0).sum(), n_act),
            "rounds_ended": (over & acting).sum(), "rounds_cleared": (acting & (env.n_remaining(s2) == 0)).sum(),
            "objects_on_table": env.n_remaining(s2).mean(), "physics_errors": s2.sim.error.sum(),
            "buffer_overflow": s2.sim.overflow.sum(), "replay_size": buffer.size, "updates": n_updates,
            "attempts": n_act, "attempts_total": attempts, "worlds_resetting": resetting.sum(),
        }
        metrics = {k: jnp.asarray(v, jnp.float32) for k, v in metrics.items()}
        return VpgState(env=s2, pushes=pushes, learner=learner, replay=buffer, key=key,
                        iteration=state.iteration + 1, attempts=attempts), metrics

    def _run_impl(self, state: VpgState, n: int):
        return jax.lax.scan(self._iteration, state, None, length=n)

    def run(self, state: VpgState, n: int):
        """Advance ``n`` iterations -> (state, metrics dict of (n,) float32 arrays)."""
        if not isinstance(n, int) or n < 1:
            raise ValueError(f"run: n must be a positive int, got {n!r}")
        self.env.prepare(state.env.n_worlds)
        return self._run_jit(state, n)


def _example(color, height) -> replay.GraspTransition:
    return replay.make_grasp_transition(color, height, jnp.zeros((3,), jnp.int32), 0.0, color, height, False)


def learner_target(cfg: Config) -> dqn.TrainState:
    """Host zeros shaped like VPG's learner for ``cfg`` (a restore target; nothing compiled)."""
    H = cfg.workspace.heightmap_px
    net = make_vpg_net(cfg.net)
    shapes = jax.eval_shape(lambda: dqn.create_train_state(init_qnet(jax.random.PRNGKey(0), net, H, H), cfg.dqn))
    return jax.tree.map(lambda x: np.zeros(x.shape, x.dtype), shapes)


def load_vpg(run_dir: str, step: Optional[int] = None):
    """VPG's trained networks in ``run_dir`` -> (its config, {"params", "batch_stats"} of the
    online VPGNet, step).  CheckpointError (one line, what to run) when the run has none."""
    d = vpg_dir(run_dir)
    if not (os.path.isdir(d) and checkpoint.checkpoint_steps(d)):
        raise checkpoint.CheckpointError(
            f"run {run_dir} has no VPG checkpoint ({d}): train one with python train.py --stage vpg --out {run_dir}")
    cfg = checkpoint.load_config(d)
    learner, step = checkpoint.restore_part(d, "learner", learner_target(cfg), step)
    return cfg, {"params": learner.params, "batch_stats": learner.batch_stats}, step


__all__ = ["VpgState", "VpgStage", "METRICS", "VPG_DIR", "vpg_dir", "stage_key", "check_config", "learner_target",
           "load_vpg"]
