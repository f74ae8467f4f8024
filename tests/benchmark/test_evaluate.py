"""Benchmark protocol (vags_jax.benchmark.protocol, eval.py): metrics by hand, bad inputs, one tiny run."""
import json
import os
import re

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import eval as eval_cli
from vags_jax.stages import checkpoint
from vags_jax import config as C
from vags_jax.rl import dqn, replay
from vags_jax.benchmark import protocol as E
from vags_jax.benchmark import requests
from vags_jax.benchmark import metrics as M
from vags_jax.policies import catalog as P
from vags_jax.stages import rundir
from vags_jax.env import EnvState
from vags_jax.nets import init_qnet, make_qnet
from vags_jax.stages.stage1 import Stage1State

from conftest import FAST_PHYSICS, TINY_TEST_OVERRIDES


def _outcomes(**kw):
    base = dict(n_objects=[2, 2, 3], attempts=[2, 5, 4], successes=[2, 1, 3], motions=[2, 5, 4],
                travel=[1.0, 2.0, 1.5], return_travel=[0.0, 1.2, 0.4], remaining=[0, 0, 0], on_object=[2, 4, 4],
                viewpoints=[0, 0, 0], error=[False, False, False], overflow=[False, False, False])
    base.update(kw)
    return M.RoundOutcomes(**{k: np.asarray(v) for k, v in base.items()})


# ----------------------------------------------------------------------------- metrics


def test_metrics_hand_computed():
    m = M.summarize(_outcomes())
    assert m["rounds"] == 3 and m["objects"] == 7 and m["attempts"] == 11 and m["successes"] == 6
    assert m["grasp_success_rate"] == pytest.approx(6 / 11)
    assert m["clearing_rate"] == pytest.approx(2 / 3)  # round 2 got 1 of 2 objects
    assert m["motion_number"] == pytest.approx(11 / 6)
    # 11 motions * 0.5 s + (4.5 + 1.6) m / 0.5 m/s + 11 attempts * (0.5 + 0.5) s + 6 * 2 s
    seconds = 5.5 + 12.2 + 11.0 + 12.0
    assert m["robot_seconds"] == pytest.approx(seconds)
    assert m["picks_per_hour"] == pytest.approx(6 * 3600 / seconds)
    assert m["objects_lost"] == 1  # round 2: 2 objects, 1 grasped, 0 left
    assert m["attempts_per_round"] == pytest.approx(11 / 3)
    assert m["on_object_rate"] == pytest.approx(10 / 11)
    fast = M.summarize(_outcomes(), M.MotionTimeModel(speed=1.0, capture_s=0, close_s=0, lift_s=0, place_s=0))
    assert fast["picks_per_hour"] == pytest.approx(6 * 3600 / 6.1)
    assert m["viewpoint_rate"] == 0.0
    # One attempt of round 2 moved the camera first: one more motion and 0.3 m more travel.
    v = M.summarize(_outcomes(motions=[2, 6, 4], viewpoints=[0, 1, 0], travel=[1.0, 2.3, 1.5]))
    assert v["motion_number"] == pytest.approx(12 / 6) and v["viewpoint_rate"] == pytest.approx(1 / 11)
    assert v["robot_seconds"] == pytest.approx(seconds + 0.5 + 0.3 / 0.5)
    assert "objects_lost_after_move" not in v  # outcomes that do not record it
    lam = M.summarize(_outcomes(viewpoints=[0, 1, 0], lost_after_move=[0, 1, 0]))
    assert lam["objects_lost"] == 1 and lam["objects_lost_after_move"] == 1
    # Round 2's lost object had already spilled from the pile before its first attempt.
    assert "objects_lost_at_start" not in v
    assert M.summarize(_outcomes(lost_at_start=[0, 1, 0]))["objects_lost_at_start"] == 1
    assert "success_after_move" not in lam and "first_attempt_success" not in lam  # not recorded
    # Round 3 moved twice and grasped once after a move; a round without attempts has no first.
    four = dict(n_objects=[2, 2, 3, 1], attempts=[2, 5, 4, 0], successes=[2, 1, 3, 0], motions=[2, 5, 6, 0],
                travel=[1.0, 2.0, 1.5, 0.0], return_travel=[0.0, 1.2, 0.4, 0.0], remaining=[0, 0, 0, 1],
                on_object=[2, 4, 4, 0], viewpoints=[0, 0, 2, 0], error=[False] * 4, overflow=[False] * 4,
                successes_after_move=[0, 0, 1, 0], first_success=[True, False, True, False])
    b = M.summarize(_outcomes(**four))
    assert b["success_after_move"] == pytest.approx(1 / 2) and b["success_direct"] == pytest.approx(5 / 9)
    assert b["first_attempt_success"] == pytest.approx(2 / 3)


def test_metrics_pool_and_edge_cases():
    a, b = _outcomes(), _outcomes(successes=[0, 0, 0], remaining=[2, 2, 3], return_travel=[1.0, 1.0, 1.0])
    m = M.summarize(M.RoundOutcomes.concatenate([a, b]))
    assert m["rounds"] == 6 and m["attempts"] == 22 and m["successes"] == 6
    assert m["grasp_success_rate"] == pytest.approx(6 / 22) and m["clearing_rate"] == pytest.approx(2 / 6)
    none = M.summarize(b)
    assert none["grasp_success_rate"] == 0.0 and none["motion_number"] is None
    assert none["picks_per_hour"] == 0.0 and none["clearing_rate"] == 0.0
    empty = M.summarize(_outcomes(attempts=[0, 0, 0], successes=[0, 0, 0], motions=[0, 0, 0],
                                  travel=[0.0] * 3, return_travel=[0.0] * 3, remaining=[2, 2, 3]))
    assert empty["grasp_success_rate"] is None and empty["picks_per_hour"] is None
    with pytest.raises(ValueError, match="speed"):
        M.MotionTimeModel(speed=0.0)


def test_table_and_json_shape():
    m = M.summarize(_outcomes())
    report = {"groups_metrics": [{"n_objects": 2, **m}], "overall": m}
    table = M.format_table(report).splitlines()
    assert len(table) == 4 and table[0].startswith("| objects") and "**overall**" in table[-1]
    assert "54.5" in table[2] and "66.7" in table[2] and "1.83" in table[2]
    json.dumps(_outcomes().to_json())
    columns = [c.strip() for c in table[0].strip("|").split("|")]
    legend = M.format_legend().splitlines()
    assert len(legend) == len(columns)  # one line per column, in the table's order
    assert all(line.split("  ")[1].strip() == c for line, c in zip(legend, columns)), legend


# ----------------------------------------------------------------------------- bad inputs


def test_bad_groups_rounds_policy(tiny_cfg):
    with pytest.raises(ValueError, match=r"outside 1\.\.3.*scene.max_objects = 3.*scene.max_objects=5"):
        E.check_groups([1, 5], tiny_cfg)
    with pytest.raises(ValueError, match="outside"):
        E.check_groups([0], tiny_cfg)
    with pytest.raises(ValueError, match="integers"):
        E.check_groups([1.5], tiny_cfg)
    with pytest.raises(ValueError, match="rounds"):
        E.check_groups([1], tiny_cfg, rounds=0)
    with pytest.raises(ValueError, match="unknown policy 'greedy'.*heuristic"):
        P.make_policy("greedy", tiny_cfg)
    with pytest.raises(ValueError, match="needs trained GDNet"):
        P.make_policy("gdnet", tiny_cfg)


def test_cli_errors(tmp_path, capsys):
    def err(argv):
        assert eval_cli.main(argv) == 2
        return capsys.readouterr().err

    assert "does not exist" in err(["--run", str(tmp_path / "nope")])
    assert "unknown policy" in err(["--policy", "nbv-unknown"])
    assert "needs --run" in err(["--policy", "gdnet"])
    assert "scene.max_objects = 3" in err(["--config", "tiny", "--policy", "random", "--groups", "1-10"])
    assert "--groups" in err(["--config", "tiny", "--policy", "random", "--groups", "1-x"])
    run = tmp_path / "run"
    checkpoint.save_config(str(run), C.tiny())
    assert "no checkpoints" in err(["--run", str(run)])
    assert requests.parse_groups("1-3,5,2") == [1, 2, 3, 5]


# ----------------------------------------------------------------------------- checkpoint


def test_load_gdnet_restores_only_the_learner(tmp_path):
    cfg = C.replace(C.tiny(), **{"replay.capacity": 8})
    H = cfg.workspace.heightmap_px
    learner = dqn.create_train_state(init_qnet(jax.random.PRNGKey(3), make_qnet(cfg.net, "gdnet"), H, H), cfg.dqn)
    c, h = jnp.zeros((H, H, 3), jnp.uint8), jnp.zeros((H, H), jnp.float32)
    buffer = replay.init(cfg.replay.capacity, replay.make_grasp_transition(c, h, jnp.zeros((3,), jnp.int32), 0.0, c, h, False))
    env_stub = {"a": jnp.ones((5, 2)), "empty": jnp.zeros((0,)), "b": jnp.arange(3)}  # any env pytree
    state = Stage1State(env=env_stub, learner=learner, replay=buffer, key=jnp.zeros((2,), jnp.uint32),
                        iteration=jnp.asarray(7, jnp.int32), attempts=jnp.asarray(35, jnp.int32))
    run = str(tmp_path / "run")
    checkpoint.save_config(run, cfg)
    checkpoint.save(run, 7, state)
    run_cfg, variables, step = rundir.load_gdnet(run)
    assert step == 7 and run_cfg == cfg
    assert checkpoint.tree_equal(variables["params"], learner.params)
    assert checkpoint.tree_equal(variables["batch_stats"], learner.batch_stats)
    # A config that does not describe the checkpoint is refused with a message.
    checkpoint.save_config(run, C.replace(cfg, **{"net.small_width": 16}))
    with pytest.raises(checkpoint.CheckpointError, match="different config"):
        rundir.load_gdnet(run)
    with pytest.raises(checkpoint.CheckpointError, match="available steps"):
        rundir.load_gdnet(run, step=3)


# ----------------------------------------------------------------------------- policies on maps


def _bars(cfg):
    H = cfg.workspace.heightmap_px
    h = np.zeros((3, H, H), np.float32)
    h[0, 14:18, 5:25] = 0.05  # bar along x: narrow along y -> closing axis 90 deg
    h[1, 5:25, 14:18] = 0.05  # bar along y -> 0 deg
    h[2, 10:13, 10:13] = 0.03
    h[2, 20:24, 20:23] = 0.06  # the higher block wins
    return h


def test_heuristic_picks_narrow_axis_on_the_highest_object():
    cfg = C.tiny()
    action, width = jax.jit(P.min_width_grasp, static_argnums=1)(jnp.asarray(_bars(cfg)), cfg)
    action, width = np.asarray(action), np.asarray(width)
    R = cfg.grasp.n_rotations
    assert action[0, 0] == R // 4 and 14 <= action[0, 1] <= 17 and 5 <= action[0, 2] <= 24
    assert action[1, 0] == 0 and 14 <= action[1, 2] <= 17
    assert 20 <= action[2, 1] <= 23 and 20 <= action[2, 2] <= 22
    assert (width <= cfg.grasp.finger_stroke).all()
    # Over half a turn, 8 rotations hold the same 8 axes (r * pi / 8): the same grasps, indices 0..7.
    half = C.replace(cfg, **{"grasp.n_rotations": 8, "net.n_rotations": 8, "grasp.half_turn": True,
                             "net.half_turn": True})
    assert half.grasp.n_axes == 8 and half.grasp.rotation_step == pytest.approx(cfg.grasp.rotation_step)
    got, got_width = jax.jit(P.min_width_grasp, static_argnums=1)(jnp.asarray(_bars(cfg)), half)
    np.testing.assert_array_equal(np.asarray(got), action)
    np.testing.assert_allclose(np.asarray(got_width), width)


def test_an_evaluation_may_turn_gdnet_over_other_rotations_but_not_change_its_network():
    from types import SimpleNamespace
    run_cfg = C.tiny()
    args = SimpleNamespace(scenes="default", objects=None)
    half = {"grasp.n_rotations": 8, "net.n_rotations": 8, "grasp.half_turn": True, "net.half_turn": True}
    cfg = requests._eval_config(args, "gdnet", run_cfg, None, half)
    assert cfg.net.n_rotations == 8 and cfg.net.half_turn and cfg.grasp.half_turn
    with pytest.raises(ValueError, match=r"must not change net\.\* \(but net\.n_rotations"):
        requests._eval_config(args, "gdnet", run_cfg, None, {**half, "net.small_width": 16})


def test_random_and_gdnet_policies_on_maps():
    cfg = C.tiny()
    h = _bars(cfg)
    z = jnp.zeros((3,), jnp.int32)
    state = EnvState(sim=None, color=jnp.zeros(h.shape + (3,), jnp.uint8), height=jnp.asarray(h),
                     attempts=z, successes=z, motions=z, travel=z.astype(jnp.float32))
    act = jax.jit(P.random_act(cfg))
    for i in range(3):
        a = np.asarray(act(None, jax.random.PRNGKey(i), state))
        assert (h[np.arange(3), a[:, 1], a[:, 2]] > 0).all() and (0 <= a[:, 0]).all() and (a[:, 0] < 16).all()
    net = make_qnet(cfg.net, "gdnet")
    variables = init_qnet(jax.random.PRNGKey(0), net, h.shape[1], h.shape[2])
    a = np.asarray(P.make_policy("gdnet", cfg, variables).act(variables, None, state))
    q = np.asarray(net.apply(variables, state.color, state.height, False))
    assert a.shape == (3, 3)
    np.testing.assert_allclose(q[np.arange(3), a[:, 0], a[:, 1], a[:, 2]], q.reshape(3, -1).max(1))
    # In groups of net.forward_batch worlds (here 2 of 3, the last group padded): the same grasps.
    grouped = C.replace(cfg, **{"net.forward_batch": 2})
    act = P.make_policy("gdnet", grouped, variables).act
    np.testing.assert_array_equal(np.asarray(act(variables, None, state)), a)
    # ... and no convolution sees more than 2 worlds' rotated images at once.
    batches = _conv_batches(jax.make_jaxpr(lambda v, st: act(v, None, st))(variables, state).jaxpr)
    assert max(batches) == 2 * cfg.net.n_rotations, batches
    # vags.direct_score=q_mean: the grasp whose two views (rotations r and r + 8 of 16) have the
    # largest mean Q, computed here with numpy.
    mean_cfg = C.replace(cfg, **{"vags.direct_score": "q_mean"})
    m = np.asarray(P.make_policy("gdnet", mean_cfg, variables).act(variables, None, state))
    both = 0.5 * (q + np.roll(q, -cfg.net.n_rotations // 2, axis=1))
    np.testing.assert_allclose(both[np.arange(3), m[:, 0], m[:, 1], m[:, 2]], both.reshape(3, -1).max(1), rtol=1e-6)
    with pytest.raises(ValueError, match="the gdnet policy plans with GDNet alone.*needs the success net"):
        P.make_policy("gdnet", C.replace(cfg, **{"vags.direct_score": "success"}), variables)


def _conv_batches(jaxpr) -> set:
    """The leading sizes of every convolution's input in a jaxpr and the jaxprs inside it."""
    out = set()
    for eqn in jaxpr.eqns:
        if eqn.primitive.name == "conv_general_dilated":
            out.add(eqn.invars[0].aval.shape[0])
        for v in eqn.params.values():
            for sub in (v if isinstance(v, (tuple, list)) else (v,)):
                inner = getattr(sub, "jaxpr", sub)
                if hasattr(inner, "eqns"):
                    out |= _conv_batches(inner)
    return out


# ----------------------------------------------------------------------------- one real tiny evaluation


@pytest.fixture(scope="module")
def tiny_eval(fast_cfg):
    # One round per group: a batch of 2 worlds, the size of test_batched_groups_...'s reset, so
    # that both use one compiled reset of the groups.  On conftest's FAST_PHYSICS (``fast_cfg``):
    # that reset is the pipeline's, which the suite compiled already, and the round loop compiles
    # faster; the checks here are the protocol's (budgets, counts, metrics, seeds), not contacts.
    cfg = C.replace(fast_cfg, **{"benchmark.max_attempts_extra": 1})
    ev = E.Evaluator(cfg)
    policy = P.make_policy("heuristic", cfg)
    report = E.evaluate(cfg, policy, groups=(1, 2), rounds=1, seed=0, evaluator=ev)
    return cfg, ev, policy, report


def test_tiny_heuristic_evaluation_is_sane(tiny_eval):
    cfg, _, _, report = tiny_eval
    assert [m["n_objects"] for m in report["groups_metrics"]] == [1, 2]
    assert cfg.scene.placement == "pile" and report["spilled_remedy"] == [0, 10]  # the default remedy, resolved
    for m in report["groups_metrics"] + [report["overall"]]:
        for k in ("grasp_success_rate", "clearing_rate"):
            assert 0.0 <= m[k] <= 1.0
        assert m["physics_errors"] == 0 and m["buffer_overflows"] == 0
        assert m["successes"] <= m["objects"]
        if m["successes"]:
            assert m["motion_number"] >= 1.0 and m["picks_per_hour"] > 0
    for k, out in report["outcomes"].items():
        k = int(k)
        n, att, succ = (np.asarray(out[f]) for f in ("n_objects", "attempts", "successes"))
        assert (n == k).all() and (att >= 1).all() and (att <= 2 * k + 1).all()
        assert (succ <= att).all() and (np.asarray(out["motions"]) == att).all()
        assert (succ <= np.asarray(out["on_object"])).all() and (np.asarray(out["on_object"]) <= att).all()
        assert (np.asarray(out["travel"]) > 0).all()
        # A round stops as soon as it is cleared, and only then before its budget.
        left = np.asarray(out["remaining"])
        assert ((att == 2 * k + 1) | (left == 0)).all()
        assert (np.asarray(out["lost_after_move"]) == 0).all()  # the heuristic never moves the camera
        start = np.asarray(out["lost_at_start"])  # a part of the objects lost
        assert ((start >= 0) & (start <= n - succ - left)).all()
        assert (np.asarray(out["successes_after_move"]) == 0).all()
        first = np.asarray(out["first_success"])
        assert (succ[first] >= 1).all()
        if k == 1:  # one object: the first attempt succeeded exactly when it cleared the round at once
            np.testing.assert_array_equal(first, (att == 1) & (succ == 1))
    overall = report["overall"]
    assert overall["attempts"] == sum(m["attempts"] for m in report["groups_metrics"])
    assert overall["success_after_move"] is None and overall["success_direct"] == overall["grasp_success_rate"]
    print(M.format_table(report))


def test_tiny_evaluation_is_reproducible(tiny_eval):
    cfg, ev, policy, report = tiny_eval
    assert report["batch_groups"]
    again = ev.run_groups(policy, 0, (1, 2), 1)
    for out, k in zip(again, ("1", "2")):  # (json: NaN scores compare equal as text)
        assert json.dumps(out.to_json()) == json.dumps(report["outcomes"][k])


def test_batched_groups_have_the_scenes_of_one_batch_per_group(tiny_eval):
    """Evaluator.run_groups gives group k's rounds the scenes Evaluator.run_group draws for
    group k alone (the same per-round keys): same objects, sizes, colours and settled poses.
    Both reset through the environment's one compiled reset of 2 worlds, the fixture's."""
    cfg, ev, _, _ = tiny_eval
    k_reset, _ = jax.random.split(jax.random.fold_in(jax.random.PRNGKey(0), 2))  # run_group's, seed 0, k = 2
    alone = ev._reset(k_reset, jnp.full((2,), 2, jnp.int32))
    batched, _ = ev.reset_groups(0, (2,), 2, 2)  # run_groups' scenes of group 2, 2 rounds
    for a, b in ((alone.sim.data.qpos, batched.sim.data.qpos), (alone.sim.active, batched.sim.active),
                 (alone.sim.geom_rgb, batched.sim.geom_rgb), (alone.sim.obj_size, batched.sim.obj_size)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


def test_seeds_write_one_report_per_seed_from_one_compiled_evaluator(tiny_eval, tmp_path, capsys, monkeypatch):
    """eval.py --seeds: each seed's report equals that seed's own evaluation, written where
    {seed} says, from the one Evaluator built (so compiled) once; then each seed's overall."""
    cfg, ev, _, report = tiny_eval
    built = []

    def evaluator(c):
        assert c == cfg
        built.append(c)
        return ev

    monkeypatch.setattr(E, "Evaluator", evaluator)
    sets = [f"{k}={v}" for k, v in {**TINY_TEST_OVERRIDES, "benchmark.max_attempts_extra": 1}.items()] + FAST_PHYSICS
    out = str(tmp_path / "seed{seed}" / "eval.json")
    assert eval_cli.main(["--config", "tiny", "--policy", "heuristic", "--groups", "1,2", "--rounds", "1",
                          "--seeds", "0,5", "--out", out, "--set"] + sets) == 0
    assert len(built) == 1
    reports = {}
    for seed in (0, 5):
        with open(tmp_path / f"seed{seed}" / "eval.json") as f:
            reports[seed] = json.load(f)
        assert reports[seed]["seed"] == seed and os.path.exists(tmp_path / f"seed{seed}" / "eval.csv")
        assert type(reports[seed]["process_s"]["programs"]) is int  # counted before the first round
    assert json.dumps(reports[0]["outcomes"]) == json.dumps(report["outcomes"])
    assert json.dumps(reports[5]["outcomes"]) != json.dumps(report["outcomes"])
    table = capsys.readouterr().out
    assert "| heuristic: seed |" in table and "| 0 |" in table and "| 5 |" in table and "| **mean** |" in table


@pytest.mark.parametrize("argv,msg", [
    (["--seeds", "1,x"], r"--seeds '1,x': expected distinct seeds"),
    (["--seeds", "3,3"], r"expected distinct seeds"),
    (["--seeds", "1,2", "--seed", "4"], r"drop --seed"),
    (["--seeds", "1,2", "--out", "a.json"], r"must contain \{seed\} with --seeds"),
])
def test_seeds_errors(argv, msg, capsys):
    assert eval_cli.main(["--config", "tiny", "--policy", "heuristic"] + argv) == 2
    assert re.search(msg, capsys.readouterr().err)


def test_scene_keys_are_each_groups_own_in_one_program():
    """``protocol._scene_keys``: group k's round keys are split from ``fold_in(PRNGKey(seed), k)``
    as ``run_group``'s (so a group's scenes do not depend on the other groups played), the
    observation and play keys from ``fold_in(PRNGKey(seed), 2**20)``; one compiled program, not
    one eager program per step."""
    from vags_jax.compile_cache import CompileClock

    with CompileClock() as clock:
        keys, counts, k_obs, k_loop = E._scene_keys(5, (2, 7), 4, 3)
    assert clock.backend == 1, clock.as_dict()
    base = jax.random.PRNGKey(5)
    for i, k in enumerate((2, 7)):
        k_sim = jax.random.split(jax.random.split(jax.random.fold_in(base, k))[0])[0]
        np.testing.assert_array_equal(keys[3 * i:3 * i + 3], jax.random.split(k_sim, 4)[:3])
    np.testing.assert_array_equal(counts, [2, 2, 2, 7, 7, 7])
    np.testing.assert_array_equal(jnp.stack([k_obs, k_loop]), jax.random.split(jax.random.fold_in(base, 1 << 20)))
    big = 2**40 + 3  # a seed past 32 bits seeds inside the program as an eager PRNGKey does
    np.testing.assert_array_equal(E._scene_keys(big, (2,), 1, 1)[2:],
                                  jax.random.split(jax.random.fold_in(jax.random.PRNGKey(big), 1 << 20)))
    spilled = E._spilled_worlds(jnp.array([[True, False], [True, True], [False, False]]), jnp.array([2, 2, 1]),
                                jnp.array([False, False, True]))
    np.testing.assert_array_equal(spilled, [True, False, False])  # the third world's physics failed
