"""Training stages 2 and 3 (paper section 3.2): VANet, then GDNet and VANet together.

Both stages play VAGS itself in B parallel worlds of ``stageN.min_objects..max_objects``
objects.  One *iteration* is, for every world at once:

  1. the gate (``vags_jax.policies.decision``): stage 2 moves the camera where GDNet's largest Q is at
     most the threshold (``vags.threshold``, or the value calibrated at stage 2's start);
     stage 3 uses ``vags.gate`` ("success": the success net's estimate of the direct grasp
     against the expected success of the grasp after a move, ``vags.view_estimate``, less
     ``vags.move_cost``; a "rate" run trains with "success": ``training_config``);
  2. DAES (``vags_jax.rl.exploration``) picks the viewpoint among object pixels with probability
     epsilon (VANet's argmax otherwise); in stage 3 it also explores GDNet's direct grasps
     (stage 2, and stage 3 with ``vags.stage3_gdnet="frozen"``, grasp directly at GDNet's
     argmax: GDNet is frozen);
  3. the attempt runs (``VagsEnv.step_attempt_or_reset``): a direct grasp (1 motion) or the move
     to the viewpoint, the close image and the close-view planner's grasp (2 motions).  Worlds
     whose round ended start a new scene in the same physics loop, as in stage 1;
  4. the new global views are rendered and GDNet's argmax and largest Q on them are computed:
     the next iteration's decision, and the "after" of eq. 5 (``view_reward``);
  5. transitions: the viewpoint worlds' into VANet's replay (action [row, col], reward
     ``view_reward``: the success of the grasp after the move, or eq. 5); GDNet's grasps -- the
     direct ones, and with the "gdnet" planner those on the fused close-view maps (not in stage 3
     with ``vags.stage3_gdnet="direct"``) -- into GDNet's replay (action [rotation, row, col],
     reward 1 on success; with ``vags.success_label="clean"`` also the success net's label, 1 on
     a success that knocked no object off the table); the last attempt of a round is terminal;
  6. ``updates_per_iteration`` updates of each learner from its replay: the success net
     (gamma 0, GDNet's replay; stages 2 and 3), GDNet (stage 3, unless ``vags.stage3_gdnet`` is
     "frozen") and VANet (``vags.vanet_gamma``);
     a learner starts once its replay holds ``learning_starts`` transitions.

GDNet's argmax and largest Q are carried from one iteration to the next (step 4), so GDNet runs
once per iteration on the global views (and once on the fused maps with the "gdnet" planner);
in stage 3 the decision uses the GDNet of the previous iteration's start.  GG-CNN is frozen.

The NBV baseline (``VagsStage(cfg, "nbv")``, ``train.py --stage nbv``) is stage 2 with an
"always move" decision: its viewpoint network (``nbv_net``: VANet's design on the small trunk)
learns with VANet's reward and replay, every attempt moves to its viewpoint (DAES explores it
as VANet's), and the success net is not trained.  Its worlds follow ``cfg.nbv``.

Everything is one ``lax.scan`` inside one jit.  ``VagsStage.run(state, n)`` advances n
iterations; running the same chunks from a restored state gives bit-identical results.  What
differs between stages 2 and 3 (the gate, whether GDNet explores and learns, what enters its
replay) is traced (``StageFlags``), so where the two stages' worlds, objects and updates match,
they run one compiled program (``vags_jax.stages.programs``): stage 3 compiles nothing.
``vags_jax.stages.pipeline`` chains them with stage 1 and GG-CNN.
"""
from __future__ import annotations

from typing import Any, Optional

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from vags_jax import batching
from vags_jax.rl import dqn, exploration, replay
from vags_jax.config import Config, Stage, Vags, replace, without_iterations
from vags_jax.policies.decision import (Decision, gate_score, gate_threshold, greedy, initial_calibration, plan_attempt,
                                        q_in_groups, update_calibration, value_at)
from vags_jax.env import EnvState, VagsEnv
from vags_jax.nets import initial_variables, make_qnet, nbv_net
from vags_jax.nets.ggcnn import GGCNN


@struct.dataclass
class VagsTrainState:
    """What stages 2 and 3 carry between iterations (a checkpointable pytree).

    env: B worlds; gdnet / vanet / success: learners (``dqn.TrainState``; GDNet is frozen in
    stage 2; the success net has GDNet's architecture and learns with gamma 0);
    vanet_replay / gdnet_replay: prioritized replays of ``GraspTransition`` (VANet's actions
    (2,) [row, col]; GDNet's (3,)); ggcnn: GG-CNN's ``{"params"}`` (frozen); threshold: ()
    float32, the "q" gate's threshold; calibration: (3,) float32 the running bias [direct, view]
    of the success estimates and the mean success after a move (``decision.update_calibration``);
    gd_grasp: (B, 3) int32 GDNet's argmax [rotation, row, col] on each world's current global view; gd_qmax: (B,) float32 its largest Q; key: (2,) uint32;
    iteration, attempts: () int32.
    """

    env: EnvState
    gdnet: dqn.TrainState
    vanet: dqn.TrainState
    success: dqn.TrainState
    vanet_replay: replay.ReplayState
    gdnet_replay: replay.ReplayState
    ggcnn: Any
    threshold: jax.Array
    calibration: jax.Array
    gd_grasp: jax.Array
    gd_qmax: jax.Array
    key: jax.Array
    iteration: jax.Array
    attempts: jax.Array


# Per-iteration metrics returned by VagsStage.run, each of shape (n,).
METRICS = (
    "success_rate", "success_direct", "success_view", "view_share", "view_bonus_rate", "explored",
    "epsilon", "loss_vanet", "td_abs_vanet", "loss_gdnet", "td_abs_gdnet", "loss_success", "td_abs_success",
    "q_max", "q_view_max", "p_direct", "p_view", "bias_direct", "bias_view", "view_success_mean",
    "threshold", "rounds_ended", "rounds_cleared", "objects_on_table", "physics_errors", "buffer_overflow",
    "replay_size_vanet", "replay_size_gdnet", "updates", "attempts", "attempts_total", "worlds_resetting",
)
# Metrics that must stay finite (train.py stops a run whose learning diverges).
FINITE_METRICS = ("loss_vanet", "td_abs_vanet", "loss_gdnet", "td_abs_gdnet", "loss_success", "td_abs_success",
                  "q_max", "q_view_max")


def view_reward(success: jax.Array, q_max_before: jax.Array, q_max_after: jax.Array, vcfg: Vags) -> jax.Array:
    """VANet's reward (``config.Vags.view_reward``): success (B,) bool, GDNet's largest Q before
    the move and on the next global view, (B,) each -> (B,) float32.  "success": 1 on success,
    else 0.  "eq5" (paper eq. 5, reconstructed): 0 on failure; ``success_reward`` +
    ``view_bonus`` * [after > before] on success."""
    if vcfg.view_reward == "success":
        return success.astype(jnp.float32)
    bonus = (q_max_after > q_max_before).astype(jnp.float32) * vcfg.view_bonus
    return jnp.where(success, vcfg.success_reward + bonus, 0.0).astype(jnp.float32)


def calibrated_threshold(q_max: jax.Array, vcfg: Vags) -> jax.Array:
    """``vags.threshold`` when set, else the ``vags.threshold_quantile`` quantile of q_max (B,)
    (GDNet's largest Q over stage 2's first global views) -> () float32."""
    if vcfg.threshold is not None:
        return jnp.asarray(vcfg.threshold, jnp.float32)
    return jnp.quantile(q_max.astype(jnp.float32), vcfg.threshold_quantile).astype(jnp.float32)


def _nbv_stage(cfg: Config) -> Stage:
    """``cfg.nbv`` with max_objects capped at scene.max_objects."""
    top = min(cfg.nbv.max_objects, cfg.scene.max_objects)
    return dataclasses.replace(cfg.nbv, max_objects=top, min_objects=min(cfg.nbv.min_objects, top))


def _example_transition(H: int, action_dim: int, labelled: bool = False):
    color, height = jnp.zeros((H, H, 3), jnp.uint8), jnp.zeros((H, H), jnp.float32)
    t = replay.make_grasp_transition(color, height, jnp.zeros((action_dim,), jnp.int32), 0.0, color, height, False)
    return replay.make_labelled_transition(t, 0.0) if labelled else t


def success_label(success: jax.Array, knocked_off: jax.Array, vcfg: Vags) -> jax.Array:
    """The success net's target (``config.Vags.success_label``): success (B,) bool, knocked_off
    (B,) int32 objects that left the table during the attempt -> (B,) float32:
    ``success_reward`` where the grasp succeeded ("grasp") and, with "clean", knocked nothing off;
    else 0."""
    good = success & (knocked_off <= 0) if vcfg.success_label == "clean" else success
    return jnp.where(good, vcfg.success_reward, 0.0).astype(jnp.float32)


@struct.dataclass
class StageFlags:
    """The switches between stages 2 and 3, each () bool and traced, so that both stages run one
    compiled program: stage3 (the gate is ``vags.gate``, else "q"), train_gdnet (GDNet explores
    and learns) and fused_to_replay (GDNet's grasps on the fused close-view maps enter its replay)."""

    stage3: jax.Array
    train_gdnet: jax.Array
    fused_to_replay: jax.Array


class VagsStage:
    """Stage 2 (``which=2``: VANet and the success net, GDNet frozen), stage 3 (``which=3``:
    all three) or the NBV baseline (``which="nbv"``: stage 2 always moving, its viewpoint network
    ``nbv_net`` alone learning).  Build once per config; ``run`` is compiled per chunk length n."""

    def __init__(self, cfg: Config, which, env: Optional[VagsEnv] = None):
        if which not in (2, 3, "nbv"):
            raise ValueError(f"VagsStage: which must be 2, 3 or 'nbv', got {which!r}")
        self.nbv = which == "nbv"
        self.cfg, self.which = training_config(cfg), 2 if self.nbv else which
        self.stage: Stage = _nbv_stage(cfg) if self.nbv else (cfg.stage2 if which == 2 else cfg.stage3)
        # Stage 3 trains GDNet unless vags.stage3_gdnet is "frozen"; "direct" keeps the fused maps out of its replay.
        self.train_gdnet = self.which == 3 and cfg.vags.stage3_gdnet != "frozen"
        self.fused_to_replay = cfg.vags.local_planner == "gdnet" and not (
            self.which == 3 and cfg.vags.stage3_gdnet == "direct")
        self.scores_by_success = cfg.vags.train_close_score == "success" and not self.nbv
        self.view_net_cfg = nbv_net(cfg.net) if self.nbv else cfg.net
        self.env = env if env is not None else VagsEnv(cfg)
        self.gdnet = make_qnet(cfg.net, "gdnet")
        self.vanet = make_qnet(self.view_net_cfg, "vanet")
        self.ggcnn = GGCNN()
        self.update_gdnet = dqn.make_update_step(self._apply_gdnet, cfg.dqn, executed_rotation_only=True)
        update_success = dqn.make_update_step(
            self._apply_gdnet, dataclasses.replace(cfg.dqn, gamma=0.0, double_q=False, symmetric_grasp_label=False),
            executed_rotation_only=True)
        # Under success_label="clean" GDNet's replay carries the success net's own target.
        self.labelled = cfg.vags.success_label != "grasp"
        self.update_success = ((lambda ts, batch, w: update_success(ts, replay.label_as_reward(batch), w))
                               if self.labelled else update_success)
        self.update_vanet = dqn.make_update_step(self._apply_vanet, dataclasses.replace(cfg.dqn, gamma=cfg.vags.vanet_gamma))
        # On an accelerator the state is donated: its buffers (two replays, 16 GB with the gpu
        # preset) are reused for the result instead of being held twice.  Not on the CPU (tests,
        # tiny runs), where memory is not the limit.
        self.donates = jax.default_backend() != "cpu"
        self._run_jit = jax.jit(self._run_impl, static_argnums=1, donate_argnums=0 if self.donates else ())
        self._greedy_jit = jax.jit(self._greedy)

    def _apply_gdnet(self, variables, color, height, train, mutable=False, rotations=None):
        return self.gdnet.apply(variables, color, height, train, rotations=rotations, mutable=mutable)

    def _apply_vanet(self, variables, color, height, train, mutable=False):
        return self.vanet.apply(variables, color, height, train, mutable=mutable)

    @staticmethod
    def _vars(ts: dqn.TrainState) -> dict:
        return {"params": ts.params, "batch_stats": ts.batch_stats}

    def _in_groups(self, fn, *args):
        """``fn(*args)`` over the worlds in groups of ``net.forward_batch`` (inference memory)."""
        return batching.map_in_groups(fn, args, self.cfg.net.forward_batch)

    def _gdnet_q(self, ts: dqn.TrainState):
        """``(color, height[, need]) -> (B, R, H, W)`` the learner's Q (eval mode), in world groups
        (``decision.q_in_groups``)."""
        return q_in_groups(lambda c, h: self._apply_gdnet(self._vars(ts), c, h, False), self.cfg.net.forward_batch)

    def close_success_q(self, success: dqn.TrainState):
        """What scores the grasps after a move besides GDNet (``plan_attempt``'s success_q): the
        success net's Q under ``vags.train_close_score="success"``, else None (GDNet's Q)."""
        return self._gdnet_q(success) if self.scores_by_success else None

    def _greedy(self, gdnet: dqn.TrainState, s: EnvState):
        """GDNet (eval mode) on the global views -> argmax (B, 3) [rotation, row, col], max (B,)."""
        return self._in_groups(lambda c, h: greedy(self._apply_gdnet(self._vars(gdnet), c, h, False)),
                               s.color, s.height)

    def _p_direct(self, success: dqn.TrainState, s: EnvState, grasp: jax.Array) -> jax.Array:
        """The success net's estimate (B,) of grasp (B, 3) on the global views (its rotation only)."""
        def one(c, h, g):
            q = self._apply_gdnet(self._vars(success), c, h, False, rotations=g[:, :1])
            return value_at(q, g.at[:, 0].set(0))

        return self._in_groups(one, s.color, s.height, grasp)

    def _n_objects(self, key: jax.Array, n_worlds: int) -> jax.Array:
        s = self.stage
        return jax.random.randint(key, (n_worlds,), s.min_objects, s.max_objects + 1, jnp.int32)

    def init(self, key: jax.Array, gdnet: dqn.TrainState, ggcnn_params, vanet: Optional[dqn.TrainState] = None,
             threshold=None, success: Optional[dqn.TrainState] = None,
             abstract_replays: bool = False) -> VagsTrainState:
        """Fresh worlds and replays.  gdnet: stage 1's learner (stage 2) or stage 2's (stage 3);
        vanet / success: None for fresh ones (stage 2: VANet from scratch, the success net from
        GDNet's variables) or stage 2's; ggcnn_params: {"params"} of GG-CNN; threshold: the "q"
        gate's threshold (stage 3: stage 2's), or None to calibrate it
        (``calibrated_threshold``) on these first views.  abstract_replays: the two replays as
        ``jax.ShapeDtypeStruct`` leaves, never allocated: a state only to compile the chunk
        program with (``compile_chunk``; ``stages.precompile``), which cannot run."""
        cfg = self.cfg
        key = jnp.asarray(key)
        if jnp.issubdtype(key.dtype, jax.dtypes.prng_key):
            key = jax.random.key_data(key)
        k_net, k_n, k_env, k_loop = jax.random.split(key, 4)
        H = cfg.workspace.heightmap_px
        if vanet is None:
            vanet = dqn.create_train_state(initial_variables(k_net, self.vanet, self.view_net_cfg, H, H), cfg.dqn)
        if success is None:
            success = dqn.create_train_state(jax.tree.map(jnp.array, self._vars(gdnet)), cfg.dqn)
        env_state = self.env.reset(k_env, np.asarray(self._n_objects(k_n, self.stage.n_worlds)))
        gd_grasp, gd_qmax = self._greedy_jit(gdnet, env_state)
        if self.nbv:  # always move: no largest Q exceeds +inf
            threshold = jnp.inf
        thr = calibrated_threshold(gd_qmax, cfg.vags) if threshold is None else jnp.asarray(threshold, jnp.float32)
        make = jax.eval_shape if abstract_replays else (lambda f: f())
        va_buffer = make(lambda: replay.init(cfg.replay.capacity, _example_transition(H, 2)))
        gd_buffer = make(lambda: replay.init(cfg.replay.capacity, _example_transition(H, 3, self.labelled)))
        # Every leaf its own buffer (``run`` donates the state, and a buffer may be donated once).
        return VagsTrainState(env=env_state, gdnet=gdnet, vanet=vanet, success=success, vanet_replay=va_buffer,
                              gdnet_replay=gd_buffer, ggcnn=ggcnn_params, threshold=thr.reshape(()),
                              calibration=initial_calibration(),
                              gd_grasp=gd_grasp, gd_qmax=gd_qmax, key=k_loop,
                              iteration=jnp.zeros((), jnp.int32), attempts=jnp.zeros((), jnp.int32))

    # ------------------------------------------------------------------ one iteration

    def _learn(self, state: VagsTrainState, va_buffer, gd_buffer, key, train_gdnet: jax.Array):
        """The iteration's updates -> (gdnet, vanet, success, gd_buffer, va_buffer, stats
        {"gdnet", "vanet", "success"} of (2,) [loss, |td|], updates done).  train_gdnet: ()
        bool, traced (stages 2 and 3 share one program): GDNet's updates run under ``lax.cond``."""
        cfg, st = self.cfg, self.stage
        k_g, k_s, k_v = jax.random.split(key, 3)
        learn = lambda upd, ts, buf, k: dqn.learn_from_replay(  # noqa: E731
            upd, ts, buf, k, cfg, st.updates_per_iteration, st.learning_starts)
        if self.nbv:  # the viewpoint network alone learns
            gdnet, gd_stats, n_gd = state.gdnet, jnp.zeros((2,), jnp.float32), 0
            success, s_stats, n_s = state.success, jnp.zeros((2,), jnp.float32), 0
        else:
            # Only the priorities pass through the cond: the transitions are read, never copied.
            def gd_learn(ts, prio, top):
                ts, buf, stats_, n = learn(self.update_gdnet, ts, gd_buffer.replace(priorities=prio, max_priority=top),
                                           k_g)
                return ts, buf.priorities, buf.max_priority, stats_, jnp.asarray(n, jnp.int32)

            def gd_frozen(ts, prio, top):
                return ts, prio, top, jnp.zeros((2,), jnp.float32), jnp.zeros((), jnp.int32)

            gdnet, prio, top, gd_stats, n_gd = jax.lax.cond(train_gdnet, gd_learn, gd_frozen, state.gdnet,
                                                            gd_buffer.priorities, gd_buffer.max_priority)
            # The success net samples by GDNet's priorities when GDNet learns (it owns the buffer then);
            # with GDNet frozen, the success net's own priorities are kept.
            success, s_buffer, s_stats, n_s = learn(self.update_success, state.success,
                                                    gd_buffer.replace(priorities=prio, max_priority=top), k_s)
            gd_buffer = s_buffer.replace(priorities=jnp.where(train_gdnet, prio, s_buffer.priorities),
                                         max_priority=jnp.where(train_gdnet, top, s_buffer.max_priority))
        vanet, va_buffer, va_stats, n_va = learn(self.update_vanet, state.vanet, va_buffer, k_v)
        stats = {"gdnet": gd_stats, "vanet": va_stats, "success": s_stats}
        return gdnet, vanet, success, gd_buffer, va_buffer, stats, n_gd + n_s + n_va

    def _decision(self, state: VagsTrainState, q_view, grasp, view, stage3: jax.Array) -> Decision:
        """The gate on the carried GDNet values: "q" in stage 2, ``vags.gate`` in stage 3
        (stage3: () bool, traced)."""
        cfg, s = self.cfg, state.env
        if self.nbv:  # no direct grasp to estimate
            p_direct = jnp.zeros_like(state.gd_qmax)
        else:
            p_direct = self._p_direct(state.success, s, state.gd_grasp)
        p_view = q_view.reshape(q_view.shape[0], -1).max(axis=1)
        score = gate_score("q", state.gd_qmax, p_direct, p_view, state.calibration, cfg.vags.view_estimate)
        thr = state.threshold
        if cfg.vags.gate != "q" and not self.nbv:
            score = jnp.where(stage3, gate_score(cfg.vags.gate, state.gd_qmax, p_direct, p_view, state.calibration,
                                                 cfg.vags.view_estimate), score)
            thr = jnp.where(stage3, gate_threshold(cfg.vags, state.threshold), thr)
        return Decision(direct=score > thr, grasp=grasp, view=view, q_max=state.gd_qmax, score=score), p_direct, p_view

    # Long (one reason): one iteration of the paper's loop, steps 1-6 of the module docstring in order.
    def _iteration(self, state: VagsTrainState, flags: "StageFlags"):
        cfg, env, st = self.cfg, self.env, self.stage
        key, k_gx, k_vx, k_img, k_obs, k_n, k_reset, k_learn = jax.random.split(state.key, 8)
        s = state.env
        B = s.n_worlds
        eps = exploration.epsilon(state.iteration, cfg.exploration)
        q_view = self._in_groups(lambda c, h: self._apply_vanet(self._vars(state.vanet), c, h, False),
                                 s.color, s.height)  # (B, H, W)
        view, v_explored = exploration.select_pixel(k_vx, q_view, s.height, eps, cfg.exploration)
        # GDNet explores its direct grasps only while it learns (stage 3).
        grasp, g_explored = exploration.select_grasp_from_greedy(
            k_gx, state.gd_grasp, cfg.net.n_rotations, s.height, eps, cfg.exploration)
        grasp = jnp.where(flags.train_gdnet, grasp, state.gd_grasp)
        g_explored = g_explored & flags.train_gdnet
        if cfg.vags.viewpoint == "grasp":  # look at the grasp GDNet would make
            view, v_explored = grasp[:, 1:], g_explored
        decision, p_direct, p_view = self._decision(state, q_view, grasp, view, flags.stage3)
        direct = decision.direct
        extra = st.max_attempts_extra
        resetting = env.round_over(s, extra) | s.sim.error  # rounds that ended last iteration
        acting = ~resetting
        attempt, close = plan_attempt(cfg, env, s, decision, k_img, self._gdnet_q(state.gdnet), state.ggcnn,
                                      self.ggcnn, self.close_success_q(state.success), acting)
        s2, result = env.step_attempt_or_reset(s, attempt, resetting, k_reset, self._n_objects(k_n, B),
                                               observe=False)
        s2 = env.with_observation(s2, k_obs if cfg.camera.noise.enabled else None)
        gd_grasp2, gd_qmax2 = self._greedy(state.gdnet, s2)
        success = result.success & acting
        over = env.round_over(s2, extra) | s2.sim.error
        viewing, direct_acting = acting & ~direct, acting & direct
        # The success net's target; the "success" gate's running estimates follow the same label.
        label = success_label(success, env.knocked_off(s, s2, success), cfg.vags)
        calibration = update_calibration(state.calibration, p_direct, p_view, label > 0, direct_acting & ~g_explored,
                                         viewing & ~v_explored, cfg.vags.calibration_decay)

        r_view = view_reward(success, state.gd_qmax, gd_qmax2, cfg.vags)
        va_buffer = replay.add(state.vanet_replay, replay.make_grasp_transition(
            s.color, s.height, view, r_view, s2.color, s2.height, over), mask=viewing)
        # GDNet's grasps: direct ones on the global maps, close-view ones on the fused maps.
        on_fused = ~direct & flags.fused_to_replay
        pick = lambda a, b: jnp.where(on_fused.reshape((-1,) + (1,) * (a.ndim - 1)), a, b)  # noqa: E731
        r_grasp = jnp.where(success, cfg.vags.success_reward, 0.0).astype(jnp.float32)
        gd_t = replay.make_grasp_transition(pick(close.color, s.color), pick(close.height, s.height),
                                            pick(close.action, grasp), r_grasp, s2.color, s2.height, over)
        if self.labelled:
            gd_t = replay.make_labelled_transition(gd_t, label)
        gd_buffer = replay.add(state.gdnet_replay, gd_t, mask=direct_acting | (acting & on_fused))
        gdnet, vanet, succ_net, gd_buffer, va_buffer, stats, n_updates = self._learn(
            state, va_buffer, gd_buffer, k_learn, flags.train_gdnet)

        n_act = acting.sum()
        n_view, n_direct = viewing.sum(), direct_acting.sum()
        view_success = (success & viewing).sum()
        attempts = state.attempts + n_act
        per = lambda num, den: num / jnp.maximum(den, 1)  # noqa: E731
        explored = jnp.where(direct, g_explored, v_explored)
        metrics = {
            "success_rate": per(success.sum(), n_act),
            "success_direct": per((success & direct_acting).sum(), n_direct),
            "success_view": per(view_success, n_view),
            "view_share": per(n_view, n_act),
            "view_bonus_rate": per((viewing & success & (gd_qmax2 > state.gd_qmax)).sum(), view_success),
            "explored": per((explored & acting).sum(), n_act),
            "epsilon": eps,
            "loss_vanet": stats["vanet"][0], "td_abs_vanet": stats["vanet"][1],
            "loss_gdnet": stats["gdnet"][0], "td_abs_gdnet": stats["gdnet"][1],
            "loss_success": stats["success"][0], "td_abs_success": stats["success"][1],
            "q_max": state.gd_qmax.mean(),
            "q_view_max": p_view.mean(),
            "p_direct": per((p_direct * acting).sum(), n_act),
            "p_view": per((p_view * acting).sum(), n_act),
            "bias_direct": calibration[0], "bias_view": calibration[1], "view_success_mean": calibration[2],
            "threshold": state.threshold,
            "rounds_ended": (over & acting).sum(),
            "rounds_cleared": (acting & (env.n_remaining(s2) == 0)).sum(),
            "objects_on_table": env.n_remaining(s2).mean(),
            "physics_errors": s2.sim.error.sum(),
            "buffer_overflow": s2.sim.overflow.sum(),
            "replay_size_vanet": va_buffer.size,
            "replay_size_gdnet": gd_buffer.size,
            "updates": n_updates,
            "attempts": n_act,
            "attempts_total": attempts,
            "worlds_resetting": resetting.sum(),
        }
        metrics = {k: jnp.asarray(v, jnp.float32) for k, v in metrics.items()}
        new_state = state.replace(env=s2, gdnet=gdnet, vanet=vanet, success=succ_net, vanet_replay=va_buffer,
                                  gdnet_replay=gd_buffer, calibration=calibration, gd_grasp=gd_grasp2,
                                  gd_qmax=gd_qmax2, key=key,
                                  iteration=state.iteration + 1, attempts=attempts)
        return new_state, metrics

    def _run_impl(self, state: VagsTrainState, n: int, flags: "StageFlags"):
        # The flags are traced, so that stages 2 and 3 (and stage 3's "all", "direct" and
        # "frozen") are one compiled program.
        return jax.lax.scan(lambda st, _: self._iteration(st, flags), state, None, length=n)

    @property
    def flags(self) -> "StageFlags":
        """This stage's traced switches (``StageFlags``)."""
        return StageFlags(stage3=jnp.asarray(self.which == 3), train_gdnet=jnp.asarray(self.train_gdnet),
                          fused_to_replay=jnp.asarray(self.fused_to_replay))

    def program_key(self):
        """What this stage's chunk program depends on: stages 2 and 3 of one config with equal
        worlds, objects and updates (``Stage`` but its name and iterations) have the same key,
        and ``use_program_of`` lets one reuse the other's compiled chunks."""
        return (self.nbv, without_iterations(self.cfg),
                tuple((f.name, getattr(self.stage, f.name)) for f in dataclasses.fields(self.stage)
                      if f.name not in ("name", "iterations")))

    def use_program_of(self, other: "VagsStage") -> None:
        """Run this stage's chunks with ``other``'s jitted program (one compile for both)."""
        if other.program_key() != self.program_key():
            raise ValueError("use_program_of: the two stages build different programs (program_key differs)")
        self._run_jit, self._greedy_jit = other._run_jit, other._greedy_jit

    # ------------------------------------------------------------------ public

    def run(self, state: VagsTrainState, n: int):
        """Advance ``n`` iterations -> (state, metrics dict of (n,) float32 arrays).  On an
        accelerator the input state is donated (``self.donates``): do not use it afterwards."""
        if not isinstance(n, int) or n < 1:
            raise ValueError(f"run: n must be a positive int, got {n!r}")
        self.env.prepare(state.env.n_worlds)
        return self._run_jit(_distinct_buffers(state), n, self.flags)

    def compile_chunk(self, state: VagsTrainState, n: int) -> None:
        """Compiles (never runs) the program ``run(state, n)`` runs: into the compile cache, for a
        later process (``stages.precompile``)."""
        self.env.prepare(state.env.n_worlds)
        self._run_jit.lower(_distinct_buffers(state), n, self.flags).compile()


def training_config(cfg: Config) -> Config:
    """The config stages 2-3 decide under: a run whose gate is "rate" trains stage 3 with the
    "success" gate, since the rate gate's table is measured on the trained networks
    (``stages.gate_measure``, after stage 3)."""
    return replace(cfg, **{"vags.gate": "success"}) if cfg.vags.gate == "rate" else cfg


def final_threshold(state: VagsTrainState, vcfg: Vags) -> jax.Array:
    """The "q" gate's threshold to keep after a stage that changed GDNet: ``vags.threshold`` when
    set, else the ``threshold_quantile`` quantile of GDNet's largest Q over the stage's last
    global views (GDNet's Q values move while it trains) -> () float32."""
    return calibrated_threshold(state.gd_qmax, vcfg).reshape(())


def _distinct_buffers(tree):
    """``tree`` with a copy of every array that appears in it more than once (a donated
    argument may hold each buffer once)."""
    leaves, treedef = jax.tree.flatten(tree)
    seen, out = set(), []
    for x in leaves:
        if id(x) in seen:
            x = jnp.array(x, copy=True)
        seen.add(id(x))
        out.append(x)
    return jax.tree.unflatten(treedef, out)


__all__ = ["VagsTrainState", "VagsStage", "StageFlags", "METRICS", "FINITE_METRICS", "view_reward", "calibrated_threshold",
           "final_threshold", "training_config"]
