"""The benchmark protocol of docs/benchmark.md (paper section 4.4): rounds of every group in one batch.

Protocol.  For every group size ``k`` (default 1..10) run ``R`` rounds (default 50).  Every
round is one world, and all rounds of all groups play at once in ONE batch of G x R worlds
(``Evaluator.run_groups``; ``evaluate(..., batch_groups=False)`` plays one group per batch):
a round of group ``k`` starts with ``k`` objects drawn from the object set (random shapes,
sizes, colours, poses: ``VagsEnv.reset``).  A round ends when the
table is clear, after ``2 * k + cfg.benchmark.max_attempts_extra`` grasp attempts, or on a physics
error.  The attempts run inside one jitted ``lax.while_loop`` that stops when every round is
over; a finished world's state is frozen (its physics may still be computed, its outcome is
dropped), so the per-world counters of ``EnvState`` are exactly the round's.

Policies (``vags_jax.policies.catalog``) plan one attempt per world; metrics, the time model
and the report table are ``vags_jax.benchmark.metrics``.  A policy that pushes (``vpg``,
``Policy.pushes``) is stepped by ``vags_jax.env.push.step_with_pushes``: a push is one motion
and no grasp attempt, counted in ``RoundOutcomes.pushes`` and in the round's budget.

Reproducible: the scenes of group ``k`` come from ``jax.random.fold_in(PRNGKey(seed), k)``,
one key per round, so adding or removing other groups does not change them (changing the
number of rounds does).  The policies' random draws and the sensor noise during the rounds
come from the seed and the whole batch.
"""
from __future__ import annotations

import dataclasses
import functools
import hashlib
import time
import warnings
from typing import Any, Callable, Optional, Sequence

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from vags_jax.benchmark.metrics import MotionTimeModel, RoundOutcomes, summarize
from vags_jax.compile_cache import CompileClock
from vags_jax.config import Config, benchmark_groups, spilled_remedy
from vags_jax.env import EnvState, VagsEnv, where_worlds
from vags_jax.env.push import step_with_pushes
from vags_jax.perception import camera
from vags_jax.policies.catalog import Policy

DEFAULT_GROUPS = tuple(range(1, 11))  # the paper's; the config's ``benchmark`` section decides
DEFAULT_ROUNDS = 50


@struct.dataclass
class _Carry:
    env: EnvState
    done: jax.Array  # (B,) bool
    return_travel: jax.Array  # (B,) float32
    on_object: jax.Array  # (B,) int32
    viewpoints: jax.Array  # (B,) int32
    lost_after_move: jax.Array  # (B,) int32 objects knocked off by attempts after a viewpoint move
    successes_after_move: jax.Array  # (B,) int32 successes of attempts after a viewpoint move
    first_success: jax.Array  # (B,) bool the round's first grasp attempt succeeded
    pushes: jax.Array  # (B,) int32 (policies that push: VPG)
    scores: jax.Array  # (B, T) float32, NaN where no attempt was made
    key: jax.Array
    t: jax.Array  # () int32
    memory: Any = None  # the policy's memory over the round (``Policy.init_memory``), or None


def check_groups(groups: Sequence[int], cfg: Config, rounds: int = 1) -> tuple[int, ...]:
    """Validates group sizes and rounds against the config; returns the groups as ints."""
    N = cfg.scene.max_objects
    groups = tuple(groups)
    if not groups:
        raise ValueError("groups: give at least one group size (number of objects), e.g. 1,2,3")
    for k in groups:
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)):
            raise ValueError(f"groups must be integers (numbers of objects), got {k!r}")
    bad = [int(k) for k in groups if not 1 <= k <= N]
    if bad:
        raise ValueError(
            f"group sizes {bad} are outside 1..{N}: the scene holds at most scene.max_objects = {N} "
            f"objects. Evaluate groups within 1..{N}, or use an evaluation config with "
            f"scene.max_objects >= {max(bad)} (e.g. --set scene.max_objects={max(bad)}; the object "
            f"pool len(scene.shapes) * scene.copies_per_shape = {cfg.scene.pool_size} must hold them "
            f"too)")
    if len(set(groups)) != len(groups):
        raise ValueError(f"groups must not repeat, got {list(groups)}")
    if isinstance(rounds, bool) or not isinstance(rounds, (int, np.integer)) or rounds < 1:
        raise ValueError(f"rounds must be a positive integer (rounds per group = parallel worlds), got {rounds!r}")
    return tuple(int(k) for k in groups)



def lifted_position(cfg: Config, position: jax.Array) -> jax.Array:
    """(B, 3) grasp points -> (B, 3) where the gripper is after the lift (the grasp primitive's
    lift height above the grasp depth, itself at least the minimum above the table)."""
    g, tz = cfg.grasp, cfg.workspace.table_z
    return jnp.stack([position[:, 0], position[:, 1],
                      jnp.maximum(position[:, 2], tz + g.min_height_above_table) + g.lift_height], 1)


def return_distance(cfg: Config, position: jax.Array, start: jax.Array) -> jax.Array:
    """(B,) metres from the lifted gripper back to the global capture pose ``start`` (3,): the
    return a failed grasp costs (``MotionTimeModel``)."""
    return jnp.linalg.norm(lifted_position(cfg, position) - start, axis=1)

class Evaluator:
    """Runs benchmark rounds for one config.  Build once; compiled once per policy (and batch
    size), reused for every group."""

    def __init__(self, cfg: Config, env: Optional[VagsEnv] = None):
        self.cfg = cfg
        self.env = env if env is not None else VagsEnv(cfg)
        self._compiled: dict[Any, Callable] = {}
        # The environment's one compiled reset (VagsEnv.reset's too): shared with training.
        self._reset = self.env.reset_unchecked
        self._reset_worlds = self.env.reset_worlds
        self._where_worlds = jax.jit(where_worlds)
        self._start = np.asarray(cfg.camera.global_position, np.float32)

    # Long (one reason): the while loop's body and its bookkeeping share one closure.
    def _rounds_impl(self, policy: Policy, params, key: jax.Array, s0: EnvState):
        """Plays B fresh rounds to their end: key (2,), s0 from ``VagsEnv.reset`` -> RoundOutcomes
        of (B,) arrays.  (The reset is its own compiled program, the same as ``VagsEnv.reset``'s, so
        that a persistent compilation cache can share it with training.)  ``policy.pushes``: the
        plan's attempts may push (``Attempt.push``): a push is one motion and no grasp
        attempt, and a round's budget of ``2 * objects + extra`` counts pushes and grasps."""
        env, cfg = self.env, self.cfg
        B = s0.n_worlds
        extra = cfg.benchmark.max_attempts_extra
        budget = jnp.max(env.max_attempts(s0.sim.n_objects, extra))
        T = 2 * cfg.scene.max_objects + extra  # the largest budget any round can have
        noise = cfg.camera.noise.enabled
        pushes = policy.pushes

        def cond(c: _Carry):
            return (~c.done.all()) & (c.t < budget)

        def body(c: _Carry):
            key, k_act, k_obs = jax.random.split(c.key, 3)
            if c.memory is None:
                attempt = policy.plan(params, k_act, env, c.env)
            else:
                attempt = policy.plan(params, k_act, env, c.env, c.memory)
            if pushes:
                s2, res, pushed = step_with_pushes(env, c.env, attempt, k_obs if noise else None)
                push = attempt.push
            else:
                s2, res = env.step_attempt(c.env, attempt, k_obs if noise else None)
                push = jnp.zeros((B,), bool)
            memory = None if c.memory is None else policy.remember(c.memory, attempt, res.success)
            # Finished worlds keep their state: their outcome is ignored.
            keep = c.done
            s2 = where_worlds(keep, c.env, s2)
            position = attempt.position
            lifted = lifted_position(cfg, position)
            if pushes:  # a push returns from where its lift ended
                lifted = jnp.where(push[:, None], pushed.end, lifted)
            back = jnp.linalg.norm(lifted - self._start, axis=1)
            ret = c.return_travel + jnp.where(keep | res.success, 0.0, back)
            pixel = camera.world_xy_to_pixel(position[:, :2], cfg.workspace)
            inside = camera.in_workspace(pixel, cfg.workspace)
            pixel = jnp.clip(pixel, 0, cfg.workspace.heightmap_px - 1)
            aimed = inside & (c.env.height[jnp.arange(B), pixel[:, 0], pixel[:, 1]] > cfg.exploration.height_threshold)
            on_obj = c.on_object + (aimed & ~keep & ~push).astype(jnp.int32)
            n_push = c.pushes + (push & ~keep).astype(jnp.int32)
            moved = (attempt.motions > 1) & ~keep
            views = c.viewpoints + moved.astype(jnp.int32)
            lost_after_move = c.lost_after_move + jnp.where(moved, env.knocked_off(c.env, s2, res.success), 0)
            after_move = c.successes_after_move + (moved & res.success).astype(jnp.int32)
            first = (c.env.attempts == 0) & ~keep & ~push  # the round's first grasp attempt
            first_success = jnp.where(first, res.success, c.first_success)
            scores = c.scores
            if attempt.score is not None:
                score = jnp.where(keep, jnp.nan, attempt.score.astype(jnp.float32))
                scores = scores.at[:, jnp.minimum(c.t, T - 1)].set(score)
            done = keep | env.round_over(s2, extra) | s2.sim.error
            if pushes:
                done = done | (s2.attempts + n_push >= env.max_attempts(s2.sim.n_objects, extra))
            return _Carry(env=s2, done=done, return_travel=ret, on_object=on_obj, viewpoints=views,
                          lost_after_move=lost_after_move, successes_after_move=after_move,
                          first_success=first_success, pushes=n_push, scores=scores, key=key, t=c.t + 1,
                          memory=memory)

        zi = jnp.zeros((B,), jnp.int32)
        # Objects drawn but gone before the first attempt (spilled from the pile's drop).
        lost_at_start = (s0.sim.n_objects - s0.sim.active.sum(axis=1)).astype(jnp.int32)
        c0 = _Carry(env=s0, done=env.round_over(s0, extra) | s0.sim.error,
                    return_travel=jnp.zeros((B,), jnp.float32), on_object=zi, viewpoints=zi, lost_after_move=zi,
                    successes_after_move=zi, first_success=jnp.zeros((B,), bool), pushes=zi,
                    scores=jnp.full((B, T), jnp.nan, jnp.float32), key=key, t=jnp.zeros((), jnp.int32),
                    memory=None if policy.init_memory is None else policy.init_memory(B))
        c = jax.lax.while_loop(cond, body, c0)
        s = c.env
        out = RoundOutcomes(
            n_objects=s.sim.n_objects, attempts=s.attempts, successes=s.successes, motions=s.motions,
            travel=s.travel, return_travel=c.return_travel, remaining=env.n_remaining(s), on_object=c.on_object,
            viewpoints=c.viewpoints, error=s.sim.error, overflow=s.sim.overflow, scores=c.scores,
            pushes=c.pushes if pushes else None, lost_after_move=c.lost_after_move,
            successes_after_move=c.successes_after_move, first_success=c.first_success, lost_at_start=lost_at_start)
        return out

    def run_group(self, policy: Policy, key, n_objects: int, rounds: int) -> RoundOutcomes:
        """``rounds`` parallel rounds of ``n_objects`` objects -> RoundOutcomes of numpy (rounds,)."""
        check_groups([n_objects], self.cfg, rounds)
        key = jnp.asarray(key)
        if jnp.issubdtype(key.dtype, jax.dtypes.prng_key):
            key = jax.random.key_data(key)
        k_reset, k_loop = jax.random.split(key)
        self.env.prepare(rounds)
        k_sim, k_obs = jax.random.split(k_reset)  # VagsEnv.reset_unchecked's keys
        s0, redraws = self.reset_scenes(jax.random.split(k_sim, rounds), jnp.full((rounds,), n_objects, jnp.int32),
                                        k_obs)  # errors: counted, not raised
        out = dataclasses.replace(self.play(policy, k_loop, s0), redraws=redraws)
        _warn_failures(out, f"{rounds} rounds with {n_objects} objects")
        return out

    def run_groups(self, policy: Policy, seed: int, groups: Sequence[int], rounds: int) -> list[RoundOutcomes]:
        """Every group's ``rounds`` rounds in ONE batch of len(groups) * rounds worlds -> one
        RoundOutcomes of numpy (rounds,) per group.  Group k's scenes are those of
        ``run_group(policy, fold_in(PRNGKey(seed), k), k, rounds)``."""
        return self.run_groups_and_scenes(policy, seed, groups, rounds)[0]

    def run_groups_and_scenes(self, policy: Policy, seed: int, groups: Sequence[int], rounds: int):
        """``run_groups`` -> (its outcomes, ``scenes_digest`` of the scenes the policy played)."""
        groups = check_groups(groups, self.cfg, rounds)
        s0, k_loop, redraws = self.reset_groups(seed, groups, rounds, rounds, with_redraws=True)
        digest = scenes_digest(s0)
        out = dataclasses.replace(self.play(policy, k_loop, s0), redraws=redraws)
        _warn_failures(out, f"{s0.n_worlds} rounds")
        return [jax.tree.map(lambda x: x[i * rounds:(i + 1) * rounds], out) for i in range(len(groups))], digest

    def reset_groups(self, seed: int, groups: Sequence[int], rounds: int, first: int, with_redraws: bool = False):
        """The first ``first`` of the ``rounds`` scenes of each group (``run_groups``'s scenes:
        group k's per-round keys come from ``fold_in(PRNGKey(seed), k)``), in one batch ->
        (EnvState of len(groups) * first worlds, the key of the rounds' play), and with
        ``with_redraws`` the (B,) redraws of ``reset_scenes`` last."""
        keys, counts, k_obs, k_loop = _scene_keys(seed, tuple(groups), rounds, first)
        self.env.prepare(first * len(groups))
        s0, redraws = self.reset_scenes(keys, counts, k_obs)
        return (s0, k_loop, redraws) if with_redraws else (s0, k_loop)

    def reset_scenes(self, keys: jax.Array, counts: jax.Array, k_obs: jax.Array):
        """The rounds' first scenes: keys (B, 2), counts (B,) int32 objects, k_obs (2,) ->
        (EnvState of B worlds, redraws (B,) int32 numpy: how often each round's spilled pile was
        drawn (``benchmark.redraw_spilled``, ``redraw_spilled``) or dropped
        (``benchmark.redrop_spilled``, ``redrop_spilled``) again; zeros with neither)."""
        redraws, redrops = spilled_remedy(self.cfg)
        if redrops:
            return redrop_spilled(self._reset_worlds, self.env.redrop_worlds, self._where_worlds, keys, counts,
                                  k_obs, redrops)
        return redraw_spilled(self._reset_worlds, self._where_worlds, keys, counts, k_obs, redraws)

    def play(self, policy: Policy, key, state: EnvState) -> RoundOutcomes:
        """Plays the rounds of ``state`` (B worlds with fresh counters: from ``VagsEnv.reset``, or
        a scripted scene) to their end with ``policy`` -> RoundOutcomes of numpy (B,).  key: (2,)."""
        key = jnp.asarray(key)
        if jnp.issubdtype(key.dtype, jax.dtypes.prng_key):
            key = jax.random.key_data(key)
        self.env.prepare(state.n_worlds)
        fn = self._compiled.get(policy.plan)
        if fn is None:
            fn = self._compiled[policy.plan] = jax.jit(lambda p, k, s: self._rounds_impl(policy, p, k, s))
        return jax.tree.map(np.asarray, jax.device_get(fn(policy.params, key, state)))


@functools.partial(jax.jit, static_argnums=(0, 1, 2, 3))
def _scene_keys(seed: int, groups: tuple, rounds: int, first: int):
    """The benchmark's per-round scene keys, in one program: with base = ``PRNGKey(seed)`` and
    groups (G,) object counts -> (keys (G * first, 2): group k's rounds 0..first-1 from
    ``fold_in(base, k)``, counts (G * first,) int32, the observation key (2,), the play key (2,)).
    The seed is static (as a Python int it seeds exactly as an eager ``PRNGKey(seed)``)."""
    base = jax.random.PRNGKey(seed)
    ks = jnp.asarray(groups, jnp.int32)

    def group_keys(k):
        k_sim = jax.random.split(jax.random.split(jax.random.fold_in(base, k))[0])[0]
        return jax.random.split(k_sim, rounds)[:first]

    keys = jax.vmap(group_keys)(ks).reshape(len(groups) * first, -1)
    k_obs, k_loop = jax.random.split(jax.random.fold_in(base, 1 << 20))
    return keys, jnp.repeat(ks, first), k_obs, k_loop


@jax.jit
def _spilled_worlds(active: jax.Array, n_objects: jax.Array, error: jax.Array) -> jax.Array:
    """(B,) bool: an object drawn for the world is off the table and its physics is intact."""
    return (active.sum(axis=1) < n_objects) & ~error


def redraw_spilled(reset: Callable, where: Callable, keys: jax.Array, counts: jax.Array, k_obs: jax.Array,
                   tries: int):
    """New scenes, drawn again where the pile's drop spilled an object: ``reset(keys (B, 2),
    counts (B,), obs_key (2,)) -> EnvState``; ``where(mask (B,), a, b)`` per world (``where_worlds``).
    -> (EnvState, redraws (B,) int32 numpy).

    A world whose drop left one of its objects off the table is drawn again from
    ``fold_in(its key, i)``, i = 1, 2, ... up to ``tries`` times, until all its objects are on
    the table; ``redraws`` counts its redraws.  A world's scene depends on its own key only (the
    first draw of its sequence that keeps every object, else its last).  Worlds whose physics
    failed are not drawn again, so that the failure is reported.  Every redraw resets the whole
    batch (one compiled program for every try).
    """
    def again(_, i):
        return reset(jax.vmap(jax.random.fold_in, (0, None))(keys, i), counts, jax.random.fold_in(k_obs, i))

    return _redo_spilled(reset(keys, counts, k_obs), again, where, tries)


def redrop_spilled(reset: Callable, redrop: Callable, where: Callable, keys: jax.Array, counts: jax.Array,
                   k_obs: jax.Array, tries: int):
    """New scenes whose spilled objects are dropped onto their piles again: ``reset(keys (B, 2),
    counts (B,), obs_key (2,)) -> EnvState``; ``redrop(state, keys, counts, obs_key) -> EnvState``
    (``VagsEnv.redrop_worlds``); ``where(mask (B,), a, b)`` per world.  -> (EnvState, redrops (B,)
    int32 numpy).

    A world whose drop left one of its objects off the table gets those objects dropped again
    (the same draws: objects, sizes, colours), up to ``tries`` times, until all are on the table;
    ``redrops`` counts the drops again.  Unlike ``redraw_spilled`` a world's draws never change,
    so two processes whose physics settles a pile differently still play the same draws.  Worlds
    whose physics failed are left as they are (the failure is reported); the others keep their
    state exactly.
    """
    def again(state, i):
        return redrop(state, keys, counts, jax.random.fold_in(k_obs, i))

    return _redo_spilled(reset(keys, counts, k_obs), again, where, tries)


def _redo_spilled(s0, again: Callable, where: Callable, tries: int):
    """Replaces, per world, the spilled rounds of s0 (an object drawn but off the table, physics
    intact) by ``again(state, i)``'s, for i = 1 .. tries while any is left -> (EnvState, how
    often each world was redone (B,) int32 numpy)."""
    done = np.zeros(s0.sim.n_objects.shape[0], np.int32)
    for i in range(1, tries + 1):
        spilled = np.asarray(jax.device_get(_spilled_worlds(s0.sim.active, s0.sim.n_objects, s0.sim.error)))
        if not spilled.any():
            break
        s0 = where(jnp.asarray(spilled), again(s0, i), s0)
        done += spilled
    return s0, done


def scenes_digest(state: EnvState) -> str:
    """A short hash of the scene draws of B worlds (object counts, colours, sizes): two methods
    played the same scenes when their digests are equal.  The settled poses are left out: the
    GPU physics (atomic adds in MuJoCo Warp) does not settle a pile bit for bit alike twice."""
    h = hashlib.sha1()
    for x in (state.sim.n_objects, state.sim.geom_rgb, state.sim.obj_size):
        h.update(np.ascontiguousarray(np.asarray(jax.device_get(x))).tobytes())
    return h.hexdigest()[:16]


def _warn_failures(out: RoundOutcomes, what: str) -> None:
    if out.error.any() or out.overflow.any():
        warnings.warn(
            f"evaluate: {int(out.error.sum())} of {what} ended in a physics error and {int(out.overflow.sum())} "
            f"overflowed a contact buffer (see vags_jax.sim.simulator); they count as not cleared (raise "
            f"Config.sim.naconmax / njmax for overflows)", RuntimeWarning, stacklevel=3)


def evaluate(cfg: Config, policy: Policy, groups: Optional[Sequence[int]] = None,
             rounds: Optional[int] = None, seed: Optional[int] = None,
             time_model: Optional[MotionTimeModel] = None, evaluator: Optional[Evaluator] = None,
             log: Optional[Callable[[str], None]] = None, batch_groups: bool = True) -> dict:
    """The whole benchmark -> report dict (JSON-ready).

    ``groups``, ``rounds`` and ``time_model`` default to the config's ``benchmark`` section
    (``config.benchmark_groups``, ``benchmark.rounds``, ``MotionTimeModel.from_config``).
    Keys: ``policy``, ``seed``, ``rounds``, ``groups``, ``time_model``, ``groups_metrics``
    (list of ``summarize`` dicts with ``n_objects``, and ``wall_s`` when groups play one
    after the other), ``overall`` (pooled), ``outcomes`` ({k: RoundOutcomes.to_json()}),
    ``wall_s``, ``scenes`` (``scenes_digest`` of the scenes played; None with ``batch_groups``
    off), ``spilled_remedy`` ([redraws, redrops] a spilled pile got: ``config.spilled_remedy``), ``compile`` (``CompileClock.as_dict()``: seconds compiling, programs compiled and
    programs loaded from the compile cache; zero seconds when the evaluator had them).
    ``seed`` defaults to ``cfg.seed``.  ``batch_groups``: every group in one batch
    (``Evaluator.run_groups``), else one batch per group (``run_group``).
    """
    groups = benchmark_groups(cfg) if groups is None else groups
    rounds = cfg.benchmark.rounds if rounds is None else rounds
    time_model = MotionTimeModel.from_config(cfg) if time_model is None else time_model
    groups = check_groups(groups, cfg, rounds)
    seed = cfg.seed if seed is None else int(seed)
    ev = evaluator if evaluator is not None else Evaluator(cfg)
    if ev.cfg != cfg:
        raise ValueError("evaluate: the evaluator was built for a different config")
    with CompileClock() as clock:
        report = _play(ev, policy, groups, rounds, seed, time_model, log, batch_groups)
    report["compile"] = clock.as_dict()
    return report


def _play(ev: Evaluator, policy: Policy, groups, rounds: int, seed: int, time_model, log, batch_groups: bool) -> dict:
    cfg = ev.cfg
    per_group, parts, raw = [], [], {}
    t_all = time.time()
    batched, scenes = ev.run_groups_and_scenes(policy, seed, groups, rounds) if batch_groups else (None, None)
    base = None if batched is not None else jax.random.PRNGKey(seed)
    for i, k in enumerate(groups):
        t0 = time.time()
        out = batched[i] if batched is not None else ev.run_group(policy, jax.random.fold_in(base, k), k, rounds)
        m = {"n_objects": k, **summarize(out, time_model)}
        if batched is None:
            m["wall_s"] = round(time.time() - t0, 2)
        per_group.append(m)
        parts.append(out)
        raw[str(k)] = out.to_json()
        if log is not None:
            log(f"group {k}: {m['successes']}/{m['attempts']} grasps, {m['rounds']} rounds"
                + (f", {m['wall_s']} s" if "wall_s" in m else ""))
    overall = summarize(RoundOutcomes.concatenate(parts), time_model)
    return {
        "policy": policy.name, "seed": seed, "rounds": rounds, "groups": list(groups),
        "max_attempts": f"2 * objects + {cfg.benchmark.max_attempts_extra}",
        "time_model": dataclasses.asdict(time_model),
        "groups_metrics": per_group, "overall": overall, "outcomes": raw,
        "wall_s": round(time.time() - t_all, 2), "batch_groups": bool(batch_groups), "scenes": scenes,
        "spilled_remedy": list(spilled_remedy(cfg)),
    }
