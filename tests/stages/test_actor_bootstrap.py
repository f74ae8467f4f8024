"""Stage 1 with ``stage1.bootstrap = "actor"``: each transition waits in replay until the next
iteration's forward pass gives it the largest Q of its world's next state; then it is learnt from.
With ``"actor_argmax"`` it waits for its world's greedy action there instead."""
import jax
import numpy as np
import pytest

from vags_jax import config as C
from vags_jax.rl import exploration
from vags_jax.stages import checkpoint
from vags_jax.stages.stage1 import Stage1, checkpoint_layout


@pytest.fixture(scope="module")
def stage(fast_cfg):
    cfg = C.replace(fast_cfg, **{"stage1.bootstrap": "actor", "stage1.learning_starts": 2,
                                 "stage1.updates_per_iteration": 2})
    return Stage1(cfg)


def _four_states(stage):
    """The stage's first state and the next three, one iteration at a time (no physics errors);
    the replay's layout is the one ``checkpoint_layout`` promises."""
    state = stage.init(jax.random.PRNGKey(5))
    layout = checkpoint_layout(stage.cfg)["replay"]
    assert jax.tree.map(lambda a: (a.shape, a.dtype), layout) == jax.tree.map(lambda a: (a.shape, a.dtype),
                                                                             state.replay)
    states = [state]
    for _ in range(3):
        state, m = stage.run(state, 1)
        states.append(state)
        assert int(m["physics_errors"][0]) == 0
    return states


def test_transitions_take_the_actors_value_of_their_next_state(stage, tmp_path):
    max_q = jax.jit(lambda ln, s: stage._apply({"params": ln.params, "batch_stats": ln.batch_stats},
                                               s.color, s.height, False).reshape(s.n_worlds, -1).max(-1))
    states = _four_states(stage)
    assert not hasattr(states[0].replay.data, "next_color")  # no next states in replay
    r = [s.replay for s in states]
    # After iteration 0 its attempts wait (priority 0): nothing to learn from yet.
    n0 = int(r[1].size)
    assert n0 == stage.cfg.stage1.n_worlds and int(jax.device_get(r[1].priorities[:n0]).max()) == 0
    # Iteration 1's forward pass gave them the max Q of their worlds' states after iteration 0,
    # by the learner iteration 1 acted with; it learnt from them at once (learning_starts = 2).
    expect = np.asarray(max_q(states[1].learner, states[1].env))[np.asarray(r[2].data.world[:n0])]
    np.testing.assert_allclose(np.asarray(r[2].data.next_value[:n0]), expect, rtol=1e-6)
    assert (np.asarray(r[2].priorities[:n0]) > 0).all()
    assert not np.allclose(jax.tree.leaves(states[2].learner.params)[0], jax.tree.leaves(states[1].learner.params)[0])
    # Iteration 2 fills iteration 1's attempts by iteration 2's learner, leaving the older values.
    n1 = int(r[2].size) - n0
    assert n1 > 0 and (np.asarray(r[2].priorities[n0:n0 + n1]) == 0).all()
    world1 = np.asarray(r[3].data.world[n0:n0 + n1])
    np.testing.assert_allclose(np.asarray(r[3].data.next_value[n0:n0 + n1]),
                               np.asarray(max_q(states[2].learner, states[2].env))[world1], rtol=1e-6)
    np.testing.assert_array_equal(np.asarray(r[3].data.next_value[:n0]), np.asarray(r[2].data.next_value[:n0]))
    # The waiting items are in the checkpoint: resumed from iteration 2, iteration 3 is the same.
    checkpoint.save(str(tmp_path), 2, states[2])
    resumed, _ = checkpoint.restore(str(tmp_path), states[2])
    assert checkpoint.tree_equal(stage.run(resumed, 1)[0], states[3])


def test_transitions_take_the_actors_greedy_action_on_their_next_state(fast_cfg, tmp_path):
    """``stage1.bootstrap = "actor_argmax"``: a transition keeps its next state and waits until the
    next iteration's pass gives it the greedy action there, by the learner that acted; the update
    then reads the target network at that action (``test_dqn.py``)."""
    stage = Stage1(C.replace(fast_cfg, **{"stage1.bootstrap": "actor_argmax", "stage1.learning_starts": 2,
                                          "stage1.updates_per_iteration": 2}))
    greedy = jax.jit(lambda ln, s: exploration.greedy_grasp(stage._apply(
        {"params": ln.params, "batch_stats": ln.batch_stats}, s.color, s.height, False)))
    states = _four_states(stage)
    r = [s.replay for s in states]
    n0 = int(r[1].size)
    assert n0 == stage.cfg.stage1.n_worlds and int(jax.device_get(r[1].priorities[:n0]).max()) == 0
    world0 = np.asarray(r[1].data.world[:n0])
    np.testing.assert_array_equal(np.asarray(r[1].data.next_color[:n0]), np.asarray(states[1].env.color)[world0])
    # Iteration 1's pass gave them the greedy action on their next states, and they were learnt from.
    np.testing.assert_array_equal(np.asarray(r[2].data.next_action[:n0]),
                                  np.asarray(greedy(states[1].learner, states[1].env))[world0])
    assert (np.asarray(r[2].priorities[:n0]) > 0).all()
    assert not np.allclose(jax.tree.leaves(states[2].learner.params)[0], jax.tree.leaves(states[1].learner.params)[0])
    n1 = int(r[2].size) - n0
    assert n1 > 0 and (np.asarray(r[2].priorities[n0:n0 + n1]) == 0).all()
    world1 = np.asarray(r[3].data.world[n0:n0 + n1])
    np.testing.assert_array_equal(np.asarray(r[3].data.next_action[n0:n0 + n1]),
                                  np.asarray(greedy(states[2].learner, states[2].env))[world1])
    checkpoint.save(str(tmp_path), 2, states[2])
    resumed, _ = checkpoint.restore(str(tmp_path), states[2])
    assert checkpoint.tree_equal(stage.run(resumed, 1)[0], states[3])


def test_clipped_values_stay_within_what_a_return_can_reach(stage):
    """stage1.bootstrap_clip: the stored value is the largest Q clipped to [0, 1 / (1 - gamma)]
    (2 at gamma 0.5); without it, the largest Q as it is."""
    q = np.zeros((3, 2, 4, 4), np.float32)
    q[0, 1, 2, 3], q[1, 0, 0, 0], q[2] = 3.9, 0.7, -0.4  # above the cap, inside, below 0
    np.testing.assert_allclose(np.asarray(stage.bootstrap_values(q)), [3.9, 0.7, -0.4])
    clipped = Stage1(C.replace(stage.cfg, **{"stage1.bootstrap_clip": True, "dqn.gamma": 0.5}), env=stage.env)
    np.testing.assert_allclose(np.asarray(clipped.bootstrap_values(q)), [2.0, 0.7, 0.0])


def test_only_stage_1_bootstraps_from_the_actor(tiny_cfg):
    with pytest.raises(ValueError, match="only stage 1"):
        C.replace(tiny_cfg, **{"stage3.bootstrap": "actor"})
    with pytest.raises(ValueError, match="double_q"):
        C.replace(tiny_cfg, **{"stage1.bootstrap": "actor", "dqn.double_q": True})
    with pytest.raises(ValueError, match="only stage 1"):
        C.replace(tiny_cfg, **{"stage2.bootstrap": "actor_argmax"})
    with pytest.raises(ValueError, match="actor_argmax.*double_q"):
        C.replace(tiny_cfg, **{"stage1.bootstrap": "actor_argmax", "dqn.double_q": True})
    with pytest.raises(ValueError, match="target_network"):
        C.replace(tiny_cfg, **{"stage1.bootstrap": "online"})
    with pytest.raises(ValueError, match="bootstrap_clip .* needs bootstrap='actor'"):
        C.replace(tiny_cfg, **{"stage1.bootstrap_clip": True})
