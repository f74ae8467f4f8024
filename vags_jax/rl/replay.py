"""Prioritized experience replay kept entirely on the accelerator.

Pure functions over a :class:`ReplayState` pytree, in the style of flashbax::

    state = init(capacity, example_transition)        # allocates (capacity, ...) per leaf
    state = add(state, transitions)                   # leaves have leading dim K (static)
    idx, batch, w = sample(state, key, b, alpha, beta)
    state = update_priorities(state, idx, td_errors, eps)

Everything is jittable with fixed shapes; ``capacity`` and the batch sizes are static.
Items added with ``pending=True`` keep priority 0 (never sampled, but counted in ``size``)
until ``fill_pending_values`` gives them their bootstrap value (stage 1's ``bootstrap =
"actor"``) or ``fill_pending_actions`` their next state's greedy action (``"actor_argmax"``).

Priorities
    Stored raw, ``p_i = |td_i| + eps``; the exponent ``alpha`` is applied at sampling time,
    ``P(i) = p_i^alpha / sum_j p_j^alpha`` over the valid slots ``[0, size)``.  New items get
    the largest priority seen so far (1.0 at the start), so each is sampled at least once with
    high probability.  Importance weights are ``w_i = (N * P(i))^-beta`` with ``N = size``,
    divided by the largest weight in the sampled batch (Schaul et al. 2016, as in Dopamine).
    Sampling draws ``b`` i.i.d. indices by inverse CDF: one ``cumsum`` over the capacity plus a
    ``searchsorted`` -- O(capacity) vectorised work per call, no sum-tree.

Storage
    The transition is any pytree the caller defines (:class:`GraspTransition` for stage 1).
    Store colour heightmaps as ``uint8`` and heights as ``float16`` (or ``bfloat16``): use
    :func:`compress_heightmap` / :func:`decompress` (or :func:`make_grasp_transition`).  At
    224 x 224 a GraspTransition is 2 x 150,528 B (colour) + 2 x 100,352 B (float16 height)
    ~= 0.5 MB, i.e. ~5 GB per 10^4 transitions.
"""
from __future__ import annotations

import dataclasses
from typing import Any, Optional

import flax.struct
import jax
import jax.numpy as jnp

from vags_jax.parallel import collectives

PyTree = Any


# ----------------------------------------------------------------------------- transitions


@flax.struct.dataclass
class GraspTransition:
    """One grasp attempt of one world (stage 1, GDNet).  Shapes are per item; the buffer and
    sampled batches add a leading dimension.

    color:       (H, W, 3) uint8   colour heightmap before the grasp
    height:      (H, W)    float16 heights in metres before the grasp
    action:      (3,)      int32   [rotation, row, col]  (VANet reuses this with (2,) [row, col])
    reward:      ()        float32
    next_color:  (H, W, 3) uint8   after the grasp
    next_height: (H, W)    float16
    done:        ()        bool    terminal: no bootstrap from the next state
    """

    color: jax.Array
    height: jax.Array
    action: jax.Array
    reward: jax.Array
    next_color: jax.Array
    next_height: jax.Array
    done: jax.Array


def compress_heightmap(height: jax.Array, dtype=jnp.float16) -> jax.Array:
    """(..., H, W) float32 metres -> same shape in ``dtype`` (float16 default, or bfloat16).

    float16 keeps ~3 significant digits: < 0.13 mm error below 0.5 m.  bfloat16 keeps ~2
    (about 1 mm at 0.3 m) but has float32's range."""
    return height.astype(dtype)


def compress_color(color: jax.Array) -> jax.Array:
    """(..., H, W, 3) colour in [0, 255] (any dtype) -> uint8 (rounded, clipped)."""
    if color.dtype == jnp.uint8:
        return color
    return jnp.clip(jnp.round(color), 0, 255).astype(jnp.uint8)


def decompress(x: jax.Array, dtype=jnp.float32) -> jax.Array:
    """Compressed heights (float16/bfloat16) -> float32 (same shape).  Colour stays uint8: the
    networks take uint8 colour."""
    return x.astype(dtype)


def make_grasp_transition(color, height, action, reward, next_color, next_height, done,
                          height_dtype=jnp.float16) -> GraspTransition:
    """Build a (batch of) :class:`GraspTransition` with storage dtypes from float inputs.

    Works for any leading batch shape; ``color`` (..., H, W, 3), ``height`` (..., H, W),
    ``action`` (..., 3), ``reward``/``done`` (...)."""
    return GraspTransition(
        color=compress_color(color),
        height=compress_heightmap(height, height_dtype),
        action=jnp.asarray(action, jnp.int32),
        reward=jnp.asarray(reward, jnp.float32),
        next_color=compress_color(next_color),
        next_height=compress_heightmap(next_height, height_dtype),
        done=jnp.asarray(done, jnp.bool_),
    )


@flax.struct.dataclass
class LabelledGraspTransition(GraspTransition):
    """A :class:`GraspTransition` with a second target, ``label`` () float32, for a learner with
    gamma 0 that shares the buffer (stages 2-3's success net under ``vags.success_label =
    "clean"``: success with no object knocked off).  A learner that reads ``reward`` treats it
    as a GraspTransition."""

    label: jax.Array


def _fields(t) -> dict:
    return {f.name: getattr(t, f.name) for f in dataclasses.fields(GraspTransition)}


def make_labelled_transition(t: GraspTransition, label) -> LabelledGraspTransition:
    """``t`` (any leading batch shape) with ``label`` (same leading shape) -> LabelledGraspTransition."""
    return LabelledGraspTransition(**_fields(t), label=jnp.asarray(label, jnp.float32))


def label_as_reward(t: LabelledGraspTransition) -> GraspTransition:
    """The GraspTransition whose reward is ``t``'s label: what the label's learner trains on."""
    return GraspTransition(**{**_fields(t), "reward": t.label})


@flax.struct.dataclass
class ValuedGraspTransition:
    """A grasp attempt stored with its bootstrap value instead of its next state (stage 1 with
    ``stage1.bootstrap = "actor"``).  Shapes per item, as :class:`GraspTransition`.

    color:      (H, W, 3) uint8   colour heightmap before the grasp
    height:     (H, W)    float16 heights in metres before the grasp
    action:     (3,)      int32   [rotation, row, col]
    reward:     ()        float32
    next_value: ()        float32 max Q over every action of the next state, as the actor's pass
                                  computed it when it acted there (0 until then: see ``add``'s
                                  ``pending``)
    done:       ()        bool    terminal: no bootstrap from the next state
    world:      ()        int32   the world (this device's index) that made the attempt
    """

    color: jax.Array
    height: jax.Array
    action: jax.Array
    reward: jax.Array
    next_value: jax.Array
    done: jax.Array
    world: jax.Array


def make_valued_transition(color, height, action, reward, done, height_dtype=jnp.float16) -> ValuedGraspTransition:
    """A batch of K :class:`ValuedGraspTransition` (leading dim K: ``color`` (K, H, W, 3),
    ``height`` (K, H, W), ``action`` (K, 3), ``reward``/``done`` (K,)) made by worlds 0..K-1,
    their ``next_value`` still 0."""
    k = jnp.shape(reward)[0]
    return ValuedGraspTransition(
        color=compress_color(color),
        height=compress_heightmap(height, height_dtype),
        action=jnp.asarray(action, jnp.int32),
        reward=jnp.asarray(reward, jnp.float32),
        next_value=jnp.zeros((k,), jnp.float32),
        done=jnp.asarray(done, jnp.bool_),
        world=jnp.arange(k, dtype=jnp.int32),
    )


@flax.struct.dataclass
class ArgmaxGraspTransition:
    """A grasp attempt stored with its next state and the action the actor chose greedily there
    (stage 1 with ``stage1.bootstrap = "actor_argmax"``): the update's target is the target
    network's value at that action, one rotation's pass instead of all.  Shapes per item:
    :class:`GraspTransition`'s fields, and

    next_action: (3,) int32 [rotation, row, col], the argmax of the online network's Q on the next
                            state as the actor computed it when it acted there (0 until then: see
                            ``add``'s ``pending``)
    world:       ()   int32 the world (this device's index) that made the attempt
    """

    color: jax.Array
    height: jax.Array
    action: jax.Array
    reward: jax.Array
    next_color: jax.Array
    next_height: jax.Array
    done: jax.Array
    next_action: jax.Array
    world: jax.Array


def make_argmax_transition(color, height, action, reward, next_color, next_height, done,
                           height_dtype=jnp.float16) -> ArgmaxGraspTransition:
    """A batch of K :class:`ArgmaxGraspTransition` made by worlds 0..K-1 (leading dim K, fields
    as :func:`make_grasp_transition`'s), their ``next_action`` still 0."""
    t = make_grasp_transition(color, height, action, reward, next_color, next_height, done, height_dtype)
    k = t.reward.shape[0]
    return ArgmaxGraspTransition(color=t.color, height=t.height, action=t.action, reward=t.reward,
                                 next_color=t.next_color, next_height=t.next_height, done=t.done,
                                 next_action=jnp.zeros((k, 3), jnp.int32), world=jnp.arange(k, dtype=jnp.int32))


# ----------------------------------------------------------------------------- buffer


@flax.struct.dataclass
class ReplayState:
    """data:         the transition pytree, every leaf with leading dim ``capacity``
    priorities:   (capacity,) float32, raw priorities (|td| + eps); 0 in never-written slots
    insert_pos:   () int32, next slot to write (ring buffer)
    size:         () int32, number of valid slots, ``min(total added, capacity)``
    max_priority: () float32, largest priority ever set (given to new items)
    """

    data: PyTree
    priorities: jax.Array
    insert_pos: jax.Array
    size: jax.Array
    max_priority: jax.Array

    @property
    def capacity(self) -> int:
        return self.priorities.shape[0]


def init(capacity: int, example_transition: PyTree) -> ReplayState:
    """Allocate an empty buffer.  ``example_transition`` is ONE transition (no batch dim); its
    leaves' shapes and dtypes define the storage (zeros of shape (capacity, *leaf.shape))."""
    if int(capacity) < 1:
        raise ValueError(f"replay capacity must be >= 1, got {capacity}")
    data = jax.tree.map(
        lambda x: jnp.zeros((capacity,) + jnp.shape(x), jnp.asarray(x).dtype), example_transition
    )
    return ReplayState(
        data=data,
        priorities=jnp.zeros((capacity,), jnp.float32),
        insert_pos=jnp.zeros((), jnp.int32),
        size=jnp.zeros((), jnp.int32),
        max_priority=jnp.ones((), jnp.float32),
    )


def add(state: ReplayState, transitions: PyTree, mask: Optional[jax.Array] = None,
        pending: bool = False) -> ReplayState:
    """Write K transitions (every leaf has leading dim K, K static and <= capacity) at the ring
    position, overwriting the oldest items once full.  New items get ``state.max_priority``.

    mask: optional (K,) bool; only the masked transitions are written (in order, packed
    together), the others are dropped.
    pending: the items get priority 0 instead, so that ``sample`` never draws them, until
    ``fill_pending_values`` gives them their bootstrap value (``ValuedGraspTransition``) or
    ``fill_pending_actions`` their next action (``ArgmaxGraspTransition``).
    """
    leaves = jax.tree.leaves(transitions)
    k = leaves[0].shape[0]
    cap = state.capacity
    if k > cap:
        raise ValueError(f"replay.add: {k} transitions exceed the capacity {cap}; add fewer at a time")
    if mask is None:
        offset, n_new = jnp.arange(k, dtype=jnp.int32), jnp.int32(k)
        idx = (state.insert_pos + offset) % cap
    else:
        mask = jnp.asarray(mask, bool)
        offset = jnp.cumsum(mask.astype(jnp.int32)) - 1
        n_new = mask.sum().astype(jnp.int32)
        idx = jnp.where(mask, (state.insert_pos + offset) % cap, cap)  # cap = out of range: dropped
    data = jax.tree.map(lambda buf, x: buf.at[idx].set(x.astype(buf.dtype), mode="drop"),
                        state.data, transitions)
    return state.replace(
        data=data,
        priorities=state.priorities.at[idx].set(0.0 if pending else state.max_priority, mode="drop"),
        insert_pos=(state.insert_pos + n_new) % cap,
        size=jnp.minimum(state.size + n_new, cap).astype(jnp.int32),
    )


def fill_pending_values(state: ReplayState, values: jax.Array) -> ReplayState:
    """Give the items the last ``add(..., pending=True)`` wrote their bootstrap value and make
    them sampleable (priority ``max_priority``, as a new item's).  ``values`` (K,) float32 is
    the largest Q of each world's current state (K worlds, as in that ``add``).

    Only that add's items can be pending (priorities are ``|td| + eps`` > 0 once set), and they
    are the K slots before ``insert_pos`` at most: those of them with priority 0 inside
    ``[0, size)`` are filled from ``values[item.world]``.  Needs ``capacity >= K``."""
    return _fill_pending(state, "next_value", values.astype(jnp.float32))


def fill_pending_actions(state: ReplayState, actions: jax.Array) -> ReplayState:
    """``fill_pending_values`` for :class:`ArgmaxGraspTransition`: ``actions`` (K, 3) int32 is
    the greedy action [rotation, row, col] of each world's current state."""
    return _fill_pending(state, "next_action", actions.astype(jnp.int32))


def _fill_pending(state: ReplayState, field: str, values: jax.Array) -> ReplayState:
    k, cap = values.shape[0], state.capacity
    idx = (state.insert_pos - 1 - jnp.arange(k, dtype=jnp.int32)) % cap
    pend = (idx < state.size) & (state.priorities[idx] == 0)
    slot = jnp.where(pend, idx, cap)  # cap = out of range: left alone
    v = values[state.data.world[idx]]
    data = state.data.replace(**{field: getattr(state.data, field).at[slot].set(v, mode="drop")})
    return state.replace(data=data, priorities=state.priorities.at[slot].set(state.max_priority, mode="drop"))


def sampleable(state: ReplayState) -> jax.Array:
    """() int32: items ``sample`` can draw (valid and not pending)."""
    valid = jnp.arange(state.capacity) < state.size
    return jnp.sum(valid & (state.priorities > 0)).astype(jnp.int32)


def sample(state: ReplayState, key: jax.Array, batch_size: int, alpha: float, beta: float,
           axis_name: Optional[str] = None):
    """Draw ``batch_size`` items i.i.d. with P(i) proportional to priority_i^alpha over the valid
    slots.  Returns ``(indices (b,) int32, transitions (leaves (b, ...)), weights (b,) float32)``;
    weights are (N P(i))^-beta normalised so that the largest in the batch is 1.
    Sampling an empty buffer returns slot 0 (zeros) with NaN weights: gate updates on
    ``state.size`` (e.g. with ``lax.cond``).

    ``axis_name`` (data parallel, one replay shard per device): each device samples its share
    of the batch from its shard, and the weights are normalised by the largest over all devices'
    samples, so that the batch as a whole is weighted as one batch.
    """
    cap = state.capacity
    valid = jnp.arange(cap) < state.size
    p = jnp.where(valid, state.priorities, 0.0) ** alpha
    p = jnp.where(valid, p, 0.0)  # 0 ** 0 == 1: keep invalid slots at zero when alpha == 0
    cdf = jnp.cumsum(p)
    total = cdf[-1]
    u = jax.random.uniform(key, (batch_size,), jnp.float32) * total
    # side="right": first slot whose cdf exceeds u; zero-probability slots are never chosen.
    idx = jnp.searchsorted(cdf, u, side="right").astype(jnp.int32)
    idx = jnp.clip(idx, 0, jnp.maximum(state.size - 1, 0))  # u rounding up to `total`
    probs = p[idx] / total
    log_w = -beta * (jnp.log(state.size.astype(jnp.float32)) + jnp.log(probs))
    weights = jnp.exp(log_w - collectives.largest(jnp.max(log_w), axis_name))
    batch = jax.tree.map(lambda buf: buf[idx], state.data)
    return idx, batch, weights


def update_priorities(state: ReplayState, indices: jax.Array, td_errors: jax.Array,
                      eps: float) -> ReplayState:
    """Set priority ``|td| + eps`` at ``indices`` (b,) from ``td_errors`` (b,).  An index drawn
    more than once gets the largest of its values: a plain scatter-set with repeated indices
    lets an unspecified write win, which made runs non-reproducible.  Updates ``max_priority``."""
    new = jnp.abs(td_errors).astype(jnp.float32) + eps
    cleared = state.priorities.at[indices].set(0.0)  # same value for repeats: deterministic
    return state.replace(
        priorities=cleared.at[indices].max(new),
        max_priority=jnp.maximum(state.max_priority, jnp.max(new)),
    )


def nbytes(state: ReplayState) -> int:
    """Bytes held by the buffer's arrays (host-side helper, not for jit)."""
    return sum(x.size * x.dtype.itemsize for x in jax.tree.leaves(state))
