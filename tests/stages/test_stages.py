"""Training end to end on CPU: the whole pipeline (stages 1, 2 and 3; no GG-CNN, which the default
close-view planner does not use) trained a few iterations, checkpointed, resumed inside stages and at stage boundaries, compared bit for bit."""
import contextlib
import io
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from types import SimpleNamespace

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import eval as eval_cli
import train
from vags_jax.stages import checkpoint, gate_measure, ggcnn as ggcnn_stage, rundir as pipeline, stage23 as vags_stages
from vags_jax.stages import pipeline as fold
from vags_jax.stages import requests
from vags_jax.benchmark import requests as eval_requests
from vags_jax.rl import replay
from vags_jax.policies import decision, rate_gate
from vags_jax.policies.catalog import vags_params
from vags_jax.policies.decision import VagsNets
from vags_jax import config as C
from vags_jax.nets.ggcnn import init_ggcnn
from vags_jax.stages.stage1 import METRICS, Stage1

from conftest import FAST_PHYSICS, TINY_TEST_OVERRIDES

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

# Stages 2 and 3 as small as stage 1 (2 worlds of 1-2 objects), and the gate table on as many
# piles, so that its reset is the stages' compiled one.  All on conftest's FAST_PHYSICS: these
# tests check the pipeline's mechanics (resumes bit for bit, hand-overs, reports), not the contacts.
# Q-network passes where used only, as the `gpu` preset (groups of one world: the skipped groups
# are exercised; tests/stages/test_forward_needed_only.py checks the actions against the full pass).
VAGS_OVERRIDES = {**{f"stage{n}.{k}": v for n in (2, 3) for k, v in
                     (("n_worlds", 2), ("max_objects", 2), ("learning_starts", 2))}, "gate_table.worlds": 2,
                  "net.forward_needed_only": "true", "net.forward_batch": 1}


def _overrides(iterations, stage2=2, stage3=4):
    """train.py --set arguments giving the tiny_cfg fixture's config with `iterations` (stage 1)."""
    over = {**TINY_TEST_OVERRIDES, **VAGS_OVERRIDES, "stage1.iterations": iterations,
            "stage2.iterations": stage2, "stage3.iterations": stage3}
    return [f"{k}={v}" for k, v in over.items()] + FAST_PHYSICS


def _metrics(path):
    with open(path) as f:
        rows = [json.loads(l) for l in f]
    for r in rows:
        r.pop("wall_s")
    return rows


def _with_ggcnn(run):
    """A GG-CNN in ``run`` for the test config: random numbers in the shapes of ``init_ggcnn``'s
    parameters (traced, not compiled: its XLA compile took 5-9 s; these tests check the
    pipeline's mechanics, not GG-CNN; tests/ggcnn/test_ggcnn_data.py trains one)."""
    cfg = C.replace(C.tiny(), **C.parse_overrides(_overrides(4)))
    shapes = jax.eval_shape(lambda: init_ggcnn(jax.random.PRNGKey(3), size=cfg.ggcnn.input_size))
    rng = np.random.default_rng(3)
    params = jax.tree.map(lambda s: rng.standard_normal(s.shape).astype(s.dtype), shapes)
    ggcnn_stage.save_ggcnn(run, params, {"steps": 0}, cfg)
    return run


@pytest.fixture(scope="module")
def pieces(tmp_path_factory, programs):
    """The whole pipeline uninterrupted (stage 1: 4 iterations, stage 2: 2, stage 3: 4; no
    GG-CNN: the "gdnet" close-view planner needs none), and the same pipeline run piece by
    piece: stage 1 for 2 iterations, resumed to 4; stage 2 alone; stage 3 for 2 iterations
    alone, then the pipeline resumed to stage 3's 4 iterations with programs built anew (as by
    a new train.py process; but the gate table's compiled step) -> {"full": dir, "split": dir, "resume_err": that last call's stderr,
    "gate_resets": the (worlds, seed) of each reset of the gate table's first piles in the uninterrupted run}."""
    from vags_jax.stages import driver

    root = tmp_path_factory.mktemp("runs")
    full, split = str(root / "full"), str(root / "split")
    base = ["--config", "tiny", "--chunk", "2", "--checkpoint-every", "1", "--quiet"]
    resets, reset = [], gate_measure._first_piles  # the gate table's first piles, counted
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(gate_measure, "_first_piles", lambda *a: resets.append(a[2:]) or reset(*a))
        assert train.main(base + ["--out", full, "--set"] + _overrides(4), programs) == 0
    assert train.main(base + ["--stage", "gdnet", "--out", split, "--set"] + _overrides(2), programs) == 0
    resume = ["--out", split, "--chunk", "2", "--quiet"]
    assert train.main(resume + ["--resume", "--stage", "gdnet", "--set", "stage1.iterations=4"], programs) == 0
    assert train.main(resume + ["--stage", "stage2"], programs) == 0
    assert train.main(resume + ["--stage", "stage3", "--set", "stage3.iterations=2"], programs) == 0
    # Stage 3's programs built anew; the gate table's step after it is the session's (compiled by
    # the uninterrupted run, same config): reloading it is not what this resume checks.
    fresh = driver.Programs()
    gate = programs.cfg_key("gate_collect", gate_measure.measure_config(checkpoint.load_config(split)))
    fresh.get(gate, lambda: programs.get(gate, None))
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        assert train.main(resume + ["--resume", "--set", "stage3.iterations=4"], fresh) == 0
    return {"full": full, "split": split, "resume_err": err.getvalue(), "gate_resets": resets}


@pytest.fixture(scope="module")
def runs(pieces):
    """(the uninterrupted run, the piecewise run) of ``pieces``."""
    return pieces["full"], pieces["split"]


@pytest.fixture(scope="module")
def target(runs, programs):
    """Stage 1's fresh state for the runs' config, the template their checkpoints restore into:
    from the session's stage (its reset already traced and compiled by the pipeline)."""
    cfg = checkpoint.load_config(runs[0])
    return programs.stage("stage1", cfg).init(jax.random.PRNGKey(cfg.seed))


def test_resume_matches_uninterrupted_run(runs, target):
    full, split = runs
    assert checkpoint.load_config(full) == checkpoint.load_config(split)
    a, step_a = checkpoint.restore(full, target)
    b, step_b = checkpoint.restore(split, target)
    assert step_a == step_b == 4
    assert int(a.iteration) == 4
    assert checkpoint.tree_equal(a, b), "resumed run diverged from the uninterrupted one"
    assert not checkpoint.tree_equal(a.learner.params, target.learner.params), "no learning happened"
    ma, mb = _metrics(os.path.join(full, "metrics.jsonl")), _metrics(os.path.join(split, "metrics.jsonl"))
    assert [r["iteration"] for r in ma] == [0, 1, 2, 3] and {r["stage"] for r in ma} == {"stage1"}
    assert ma == mb


def _stage_arrays(run, name):
    d = pipeline.stage_dir(run, name)
    return checkpoint.read(d, pipeline.progress(run, name))


def test_pipeline_resumed_at_stage_boundaries_matches_uninterrupted_run(runs):
    """Stages 2 and 3 of the piecewise run (stage 2 started alone from stage 1's checkpoint,
    stage 3 started alone and resumed inside) equal the uninterrupted pipeline's, bit for bit:
    checkpoints, exported networks and metrics."""
    full, split = runs
    assert checkpoint.load_config(full) == checkpoint.load_config(split)
    for name, steps in (("stage2", 2), ("stage3", 4)):
        a, step_a = _stage_arrays(full, name)
        b, step_b = _stage_arrays(split, name)
        assert step_a == step_b == steps
        assert a.keys() == b.keys() and all(
            a[p].keys() == b[p].keys() and all(np.array_equal(a[p][k], b[p][k]) for k in a[p]) for p in a), name
        na, _ = checkpoint.read(pipeline.networks_dir(full, name))
        nb, _ = checkpoint.read(pipeline.networks_dir(split, name))
        assert all(np.array_equal(na[p][k], nb[p][k]) for p in na for k in na[p])
        ma = _metrics(os.path.join(full, name, "metrics.jsonl"))
        assert [r["iteration"] for r in ma] == list(range(steps)) and {r["stage"] for r in ma} == {name}
        assert ma == _metrics(os.path.join(split, name, "metrics.jsonl"))
    with open(os.path.join(full, "timings.jsonl")) as f:
        assert [json.loads(l)["stage"] for l in f] == ["stage1", "stage2", "stage3", "gate"]  # no GG-CNN trained
    assert not os.path.exists(os.path.join(full, "ggcnn")) and pipeline.load_vags(full).ggcnn is None


def _timings(run):
    with open(os.path.join(run, "timings.jsonl")) as f:
        return [json.loads(l) for l in f]


def test_chunks_after_the_first_compile_nothing(runs):
    """Stages 1 and 3 of the pipeline ran 2 chunks each (and the piecewise run resumed twice):
    no chunk after a segment's first compiled or loaded a program (timings.jsonl counts them)."""
    for run in runs:
        rows = [r for r in _timings(run) if r["stage"] != "gate"]  # the gate's table is measured in one go
        assert rows and all(r["compile"]["recompiled_chunks"] == [] for r in rows), rows
        assert all({"seconds", "compiled", "loaded"} <= r["compile"].keys() for r in rows)


def test_a_resume_in_a_new_process_loads_its_programs(pieces):
    """Stage 3 of the piecewise run resumed with programs built anew (as by a new train.py
    process, in the ``pieces`` fixture): the compile cache that the runs filled serves some of
    its programs.  (It runs one chunk, so its ``recompiled_chunks`` is empty by construction;
    ``test_chunks_after_the_first_compile_nothing`` checks runs of several chunks.)  Since
    ``vags_jax.lowering`` the chunk lowers to the same text whatever the process traced before,
    so it loads (bench/RESULTS.md, "Resume on CPU loads its chunk")."""
    run = pieces["split"]
    assert "stage3's chunk of 2 iterations" in pieces["resume_err"]
    last = [r for r in _timings(run) if r["stage"] == "stage3"][-1]
    assert (last["stage"], last["from"], last["to"]) == ("stage3", 2, 4)
    assert last["compile"]["loaded"] > 0, last["compile"]
    assert last["compile"]["recompiled_chunks"] == []


def test_a_rate_gate_run_trains_stage_3_with_the_success_gate(tiny_cfg):
    """The "rate" gate's table is measured on the trained networks, so stage 3 of such a run
    decides with the "success" gate (``stage23.training_config``); other gates train as set,
    and a "rate" run that would measure no table is refused."""
    rate = C.replace(tiny_cfg, **{"vags.gate": "rate"})
    assert vags_stages.training_config(rate) == C.replace(tiny_cfg, **{"vags.gate": "success"})
    for gate in ("q", "success"):
        cfg = C.replace(tiny_cfg, **{"vags.gate": gate})
        assert vags_stages.training_config(cfg) is cfg
    requests.check_trainable_gate(rate)
    with pytest.raises(ValueError, match="gate_table.worlds=0 skips it"):
        requests.check_trainable_gate(C.replace(rate, **{"gate_table.worlds": 0}))


def test_stage_hand_over(runs):
    """Stage 2 starts from stage 1's final GDNet and never changes it (its success net starts as
    a copy of it and learns); stage 3 starts from stage 2's networks and threshold and re-sets
    the "q" gate's threshold on its last views; the replays hold exactly the transitions the
    metrics count (with the "gdnet" close-view planner every attempt is a GDNet grasp)."""
    full, _ = runs
    cfg = checkpoint.load_config(full)
    assert cfg.vags.local_planner == "gdnet"
    gd1 = pipeline.stage1_gdnet(full, cfg)
    gd2, va2, su2, thr2 = pipeline.stage2_result(full, cfg)
    assert checkpoint.tree_equal(gd1, gd2), "stage 2 changed the frozen GDNet"
    nets = pipeline.load_vags(full, cfg, gdnet="stage3")  # stage 3's own, whichever the gate table kept
    last3, _ = _stage_arrays(full, "stage3")
    gd_qmax = np.concatenate([np.ravel(v) for v in last3["gd_qmax"].values()])
    assert nets.source == "stage3 step 4" and nets.success is not None
    before3 = pipeline.load_vags(full, cfg, stage="stage2")  # eval.py --networks stage2
    assert before3.source == "stage2 step 2" and checkpoint.tree_equal(before3.gdnet["params"], gd1.params)
    assert float(nets.q_threshold) == pytest.approx(float(np.quantile(gd_qmax, cfg.vags.threshold_quantile)))
    rows2 = _metrics(os.path.join(full, "stage2", "metrics.jsonl"))
    rows3 = _metrics(os.path.join(full, "stage3", "metrics.jsonl"))
    for rows in (rows2, rows3):
        for r in rows:
            assert set(vags_stages.METRICS) <= set(r)
            assert 0.0 <= r["view_share"] <= 1.0 and 0.0 <= r["success_rate"] <= 1.0
            assert r["physics_errors"] == 0 and r["threshold"] == pytest.approx(float(thr2))
            assert r["attempts"] + r["worlds_resetting"] == 2
        viewed = sum(round(r["view_share"] * r["attempts"]) for r in rows)
        assert rows[-1]["replay_size_vanet"] == viewed
    # Stage 2's grasps on fused maps train the success net; stage 3 ("all", the default) trains
    # GDNet on them too.
    assert cfg.vags.stage3_gdnet == "all"
    assert sum(round(r["view_share"] * r["attempts"]) for r in rows3) > 0, "stage 3 needs moves for this check"
    assert rows2[-1]["replay_size_gdnet"] == sum(r["attempts"] for r in rows2)
    assert rows3[-1]["replay_size_gdnet"] == sum(r["attempts"] for r in rows3)
    assert all(r["loss_gdnet"] == 0 for r in rows2)
    if any(r["updates"] for r in rows2):
        assert not checkpoint.tree_equal(su2.params, gd1.params), "the success net did not learn in stage 2"
    if any(r["updates"] for r in rows3):
        assert not checkpoint.tree_equal(nets.gdnet["params"], gd2.params) or \
            not checkpoint.tree_equal(nets.vanet["params"], va2.params)


def test_stage3_direct_keeps_its_fused_map_grasps_out_of_gdnets_replay(runs, programs):
    """``vags.stage3_gdnet="direct"``: stage 3 from the run's stage-2 networks, 4 iterations in
    memory in chunks of 2 (the program the pipeline compiled for "all": the mode is a traced
    flag); GDNet and the success net learn, and GDNet's replay holds its global-view grasps
    only.  "frozen" takes stage 2's paths (GDNet's greedy grasps, no GDNet update:
    ``test_stage_hand_over`` checks them on stage 2), and "all" the default's
    (``test_stage_hand_over``: every grasp in GDNet's replay)."""
    full, _ = runs
    base = checkpoint.load_config(full)
    env = programs.env(base)  # the env does not depend on the mode
    modes = {m: vags_stages.VagsStage(C.replace(base, **{"vags.stage3_gdnet": m}), 3, env)
             for m in ("all", "direct", "frozen")}
    assert [(p.train_gdnet, p.fused_to_replay) for p in modes.values()] == [(True, True), (True, False), (False, True)]
    gd2, va2, su2, thr2 = pipeline.stage2_result(full, base)
    program = modes["direct"]
    # The "success" gate starts from an optimistic mean success after a move (1), so the tiny run
    # can move the camera on all but one of its 8 attempts, and GDNet's replay needs
    # learning_starts direct grasps before GDNet and the success net learn: less optimistic
    # starts (the state's calibration, traced: the same program) until it gets them, moves left.
    start = program.init(pipeline.stage_key(base, "stage3"), gd2, None, va2, thr2, su2)
    assert base.vags.gate == "success" and base.vags.view_estimate == "mean"  # the gate this works on
    for after_move in (1.0, 0.9, 0.8, 0.7, 0.5):
        state, metrics = fold.run_stage(fold.stage_fns("stage3", program), start.replace(
            calibration=start.calibration.at[2].set(after_move)), 4, chunk=2)
        m = {k: np.concatenate([np.asarray(c[k]) for c in metrics]) for k in metrics[0]}
        direct = np.round((1 - m["view_share"]) * m["attempts"]).sum()
        if base.stage3.learning_starts <= direct < m["attempts"].sum():
            break
    assert m["updates"].sum() > 0
    assert base.stage3.learning_starts <= direct < m["attempts"].sum(), "the test needs direct grasps and moves"
    assert not checkpoint.tree_equal(state.success.params, su2.params), "the success net did not learn"
    assert not checkpoint.tree_equal(state.gdnet.params, gd2.params), "GDNet did not learn in stage 3"
    assert int(state.gdnet_replay.size) == direct, "a grasp on a fused map reached GDNet's replay"


def test_train_close_score_success_plans_the_grasp_after_a_move_by_the_success_net(runs, programs, monkeypatch):
    """``vags.train_close_score="success"``: stages 2-3 score the grasp after a move by the
    success net's Q (here unlike GDNet's), which the iteration hands ``plan_attempt`` (traced
    up to it, nothing compiled); the default hands none (GDNet's Q), nor does the NBV baseline,
    which trains no success net."""
    full, _ = runs
    base = checkpoint.load_config(full)
    env = programs.env(base)
    gd2, va2, su2, thr2 = pipeline.stage2_result(full, base)
    su2 = su2.replace(params=jax.tree.map(lambda x: -x, su2.params))  # unlike GDNet's, whatever stage 2 learned
    stages = {score: vags_stages.VagsStage(C.replace(base, **{"vags.train_close_score": score}), 2, env)
              for score in ("q", "success")}
    assert stages["q"].close_success_q(su2) is None
    state = stages["success"].init(pipeline.stage_key(base, "stage2"), gd2, None, va2, thr2, su2,
                                   abstract_replays=True)
    c, h = state.env.color, state.env.height
    got = stages["success"].close_success_q(su2)(c, h)
    np.testing.assert_allclose(got, stages["success"]._gdnet_q(su2)(c, h), rtol=1e-5, atol=1e-6)
    assert not np.allclose(got, stages["success"]._gdnet_q(gd2)(c, h))

    handed = []

    class Stop(Exception):
        pass

    def fake_plan(*args, **kwargs):
        handed.append(args[8] if len(args) > 8 else kwargs.get("success_q"))
        raise Stop

    monkeypatch.setattr(vags_stages, "plan_attempt", fake_plan)
    for score in ("q", "success"):
        with pytest.raises(Stop):
            jax.eval_shape(stages[score]._iteration, state, stages[score].flags)
    assert handed[0] is None and handed[1] is not None
    assert not vags_stages.VagsStage(C.replace(base, **{"vags.train_close_score": "success"}), "nbv",
                                     env).close_success_q(su2)


def test_success_label_is_the_grasp_or_the_grasp_that_knocked_nothing_off():
    """``vags.success_label``: "grasp" labels every successful grasp, "clean" only those during
    which no object left the table; both at ``success_reward``."""
    success = jnp.array([True, True, False, False])
    knocked = jnp.array([0, 2, 0, 1], jnp.int32)
    vcfg = C.Vags(success_reward=2.0)
    np.testing.assert_array_equal(vags_stages.success_label(success, knocked, vcfg), [2.0, 2.0, 0.0, 0.0])
    np.testing.assert_array_equal(
        vags_stages.success_label(success, knocked, C.replace(vcfg, success_label="clean")), [2.0, 0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="success_label must be one of"):
        C.replace(C.tiny(), **{"vags.success_label": "tidy"})


def test_success_label_clean_trains_the_success_net_on_its_label(runs, programs):
    """``vags.success_label="clean"``: GDNet's replay in stages 2-3 carries the label
    (``LabelledGraspTransition``; traced, not compiled), and the success net's update on such a
    batch is the default's update on the same batch with the label as reward, not the reward."""
    full, _ = runs
    base = checkpoint.load_config(full)
    env = programs.env(base)
    gd2, va2, su2, thr2 = pipeline.stage2_result(full, base)
    stages = {lab: vags_stages.VagsStage(C.replace(base, **{"vags.success_label": lab}), 2, env)
              for lab in ("grasp", "clean")}
    for lab, kind in (("grasp", replay.GraspTransition), ("clean", replay.LabelledGraspTransition)):
        st = stages[lab]
        state = st.init(pipeline.stage_key(base, "stage2"), gd2, None, va2, thr2, su2, abstract_replays=True)
        out, _ = jax.eval_shape(st._iteration, state, st.flags)
        assert type(out.gdnet_replay.data) is kind, lab
    H, b, R = base.workspace.heightmap_px, base.dqn.batch_size, base.net.n_rotations
    rng = np.random.default_rng(0)
    t = replay.make_grasp_transition(
        rng.integers(0, 256, (b, H, H, 3)), rng.uniform(0, 0.05, (b, H, H)),
        np.stack([rng.integers(0, R, b), rng.integers(0, H, b), rng.integers(0, H, b)], 1), np.ones(b),
        rng.integers(0, 256, (b, H, H, 3)), rng.uniform(0, 0.05, (b, H, H)), np.zeros(b, bool))
    batch = replay.make_labelled_transition(t, np.arange(b) % 2)  # every grasp succeeded, half clean
    w = jnp.ones((b,), jnp.float32)
    clean = jax.jit(stages["clean"].update_success)(su2, batch, w)
    grasp = jax.jit(stages["grasp"].update_success)
    on_label = grasp(su2, replay.label_as_reward(batch), w)
    on_reward = grasp(su2, t, w)
    assert checkpoint.tree_equal(clean[0].params, on_label[0].params)
    np.testing.assert_array_equal(clean[2], on_label[2])  # the TD errors
    assert not checkpoint.tree_equal(clean[0].params, on_reward[0].params)


def test_train_throughput_times_stage_3_from_the_runs_networks(runs, programs, monkeypatch):
    """bench/train_throughput.py --stage stage3: stage 3's whole iterations from the run's saved
    networks, in the pipeline's chunks, on the stage program the pipeline compiled; then its
    phases, each compiled alone (one call: the compiling up to the phases is read as they start)."""
    sys.path.insert(0, os.path.join(ROOT, "bench"))
    import train_throughput

    from vags_jax.compile_cache import CompileClock

    full, _ = runs
    cfg = checkpoint.load_config(full)
    before_phases = []
    phases = train_throughput.vags_stage_phases
    monkeypatch.setattr(train_throughput, "vags_stage_phases",
                        lambda *a, **k: before_phases.append(clock.as_dict()) or phases(*a, **k))
    with CompileClock() as clock:
        r = train_throughput.vags_stage_iterations(cfg, full, "stage3", 2, programs, chunk=2, reps=1)
    assert r["stage"] == "stage3" and r["iterations_timed"] == 2 and r["chunk"] == 2
    assert r["attempts"] > 0 and r["updates"] > 0 and r["attempts_per_s"] == pytest.approx(r["attempts"] / r["wall_s"])
    # The chunk program is the pipeline's: compiling before the phases is the few small programs
    # of restoring the networks, a fraction of the seconds the pipeline's stages 2-3 compiled for.
    stage2_compile = next(t for t in _timings(full) if t["stage"] == "stage2")["compile"]["seconds"]
    assert len(before_phases) == 1 and before_phases[0]["seconds"] < 0.2 * stage2_compile, (before_phases, stage2_compile)
    assert clock.seconds > before_phases[0]["seconds"]  # the phases compiled after it
    ph = r["phases"]
    assert set(ph) - {"rest_of_iteration_s"} == {"vanet_and_gate_s", "attempt_plan_close_view_s", "physics_s", "render_heightmaps_s",
                       "gdnet_next_views_s", "updates_s"}
    assert all(v > 0 for k, v in ph.items() if k != "rest_of_iteration_s"), ph


def test_stages_2_and_3_run_one_compiled_program(runs):
    """Stages 2 and 3 of one config differ only in traced switches (``StageFlags``): built by
    one ``Programs``, stage 3 runs stage 2's jitted chunk, and the pipeline's stage 3 compiled
    nothing of its own (its start loads stage 2's programs; ``timings.jsonl``).  Stages whose
    worlds differ build their own programs, and one refuses the other's."""
    from vags_jax.stages.programs import Programs

    full, _ = runs
    cfg = checkpoint.load_config(full)
    progs = Programs()
    s2, s3 = progs.stage("stage2", cfg), progs.stage("stage3", cfg)
    assert s2.which == 2 and s3.which == 3 and s3._run_jit is s2._run_jit
    assert bool(s3.flags.stage3) and not bool(s2.flags.stage3) and bool(s3.flags.train_gdnet)
    stage3 = [r for r in _timings(full) if r["stage"] == "stage3"]
    assert stage3 and stage3[0]["compile"]["compiled"] == 0, stage3[0]["compile"]
    other = C.replace(cfg, **{"stage3.n_worlds": cfg.stage3.n_worlds + 1})
    progs2 = Programs()
    o2, o3 = progs2.stage("stage2", other), progs2.stage("stage3", other)
    assert o3._run_jit is not o2._run_jit
    with pytest.raises(ValueError, match="program_key"):
        o3.use_program_of(o2)


def test_precompile_compiles_the_programs_a_resumed_stage_loads(runs, capsys):
    """``stages.precompile`` builds stage 2 from placeholder networks and compiles its chunk, and
    the gate table's step: every program it needs was already compiled by the fixture's
    ``train.py --stage stage2`` and its pipeline's gate table (their inputs restored from
    checkpoints), so here all are loaded from the session's compile cache and none compiled,
    i.e. the same programs.  Its command line refuses bad input in one
    line with exit code 2."""
    from vags_jax.stages import precompile
    from vags_jax.stages.programs import Programs

    _, split = runs
    cfg = checkpoint.load_config(split)
    report = precompile.precompile(cfg, ["stage2", "gate"], chunk=2, programs=Programs(), log=lambda m: None)
    got = report["stage2"]
    assert got["iterations_per_chunk"] == 2
    assert got["compile"]["compiled"] == 0 and got["compile"]["loaded"] >= 3, got
    # The gate table's step from placeholder networks: the one the pipeline measured with real ones.
    assert report["gate"]["compile"]["compiled"] == 0 and report["gate"]["compile"]["loaded"] >= 1, report
    for argv, message in ((["--stages", "stage4"], "--stages takes"),
                          (["--run", split, "--config", "tiny"], "--run takes"),
                          (["--run", split + "_missing"], "does not exist")):
        try:
            code = precompile.main(argv)
        except SystemExit as e:  # argparse's errors
            code = e.code
        err = capsys.readouterr().err
        assert code == 2 and message in err and err.count("\n") == 1, (argv, err)


def test_the_run_keeps_the_gdnets_whose_gate_table_picks_most(runs, pieces, tmp_path):
    """``vags.stage3_gdnet_pick="rate"``: the pipeline measured the gate table with stage 3's
    GDNet, with stage 2's, and with stage 2's for direct grasps and stage 3's after a move
    ("split"), and kept the one whose table picks most per second (a tie keeps the earlier);
    ``load_vags`` gives the kept GDNets and the direct one's "q" threshold, the table only to
    networks with those GDNets, and the close-view planner plays the close one."""
    full, _ = runs
    cfg = checkpoint.load_config(full)
    with open(os.path.join(full, "gate.json")) as f:
        saved = json.load(f)
    tried = saved["gdnet_pick"]
    assert list(tried) == ["stage3", "stage2", "split"]
    want = {"stage3": ("stage3 step 4", "stage3 step 4"), "stage2": ("stage2 step 2", "stage2 step 2"),
            "split": ("stage2 step 2", "stage3 step 4")}
    assert {k: (v["gdnet"], v["close_gdnet"]) for k, v in tried.items()} == want
    assert pieces["gate_resets"] == [(2, 0)], "the three tables start from one reset of the same first piles"
    kept = max(tried, key=lambda k: (tried[k]["rate"], -list(tried).index(k)))
    assert (saved["gdnet"], saved["close_gdnet"]) == want[kept] and saved["networks"] == "stage3 step 4"
    assert saved["rate"] == pytest.approx(tried[kept]["rate"])
    assert tried["split"]["direct_success"] == tried["stage2"]["direct_success"], "one direct GDNet, other states"
    # Every pick on a copy of the run's networks, whatever this run's was.
    run = str(tmp_path / "run")
    for part in ("stage2/networks", "stage3/networks"):
        shutil.copytree(os.path.join(full, part), os.path.join(run, part))
    shutil.copy(os.path.join(full, checkpoint.CONFIG_FILE), run)
    own3 = pipeline.load_vags(full, cfg, gdnet="stage3")
    own2 = pipeline.load_vags(full, cfg, stage="stage2")
    nets_fn = VagsNets(cfg)
    H = cfg.workspace.heightmap_px
    color = np.zeros((1, H, H, 3), np.float32)
    height = np.linspace(0, 0.05, H * H, dtype=np.float32).reshape(1, H, H)
    q = {k: np.asarray(nets_fn.gdnet_q(v.gdnet)(color, height)) for k, v in (("stage2", own2), ("stage3", own3))}
    assert not np.array_equal(q["stage2"], q["stage3"]), "the test needs two different GDNets"
    for pick, (direct, close) in want.items():
        with open(os.path.join(run, "gate.json"), "w") as f:
            json.dump({**saved, "gdnet": direct, "close_gdnet": close}, f)
        nets = pipeline.load_vags(run, cfg)
        assert (nets.source, nets.gdnet_source, nets.close_source) == ("stage3 step 4", direct, close)
        direct_own = own2 if direct.startswith("stage2") else own3
        assert checkpoint.tree_equal(nets.gdnet, direct_own.gdnet)
        assert float(nets.q_threshold) == float(direct_own.q_threshold)
        assert checkpoint.tree_equal(nets.vanet, own3.vanet) and nets.gate_table is not None
        params = vags_params(nets, cfg)
        got = np.asarray(nets_fn.close_q(params)(color, height))
        assert np.array_equal(got, q[close.split(" ")[0]]), f"{pick}: the grasp after a move used another GDNet"
        last = pipeline.load_vags(run, C.replace(cfg, **{"vags.stage3_gdnet_pick": "last"}))
        assert checkpoint.tree_equal(last.gdnet, own3.gdnet) and last.close_gdnet is None
        assert (last.gate_table is None) == (pick != "stage3"), "a table served to other GDNets"
        # eval.py --set vags.stage3_gdnet_pick=last loads stage 3's GDNet too.
        _, played, _, _ = eval_requests._run_config(SimpleNamespace(run=run, step=None, networks=None), "vags",
                                               {"vags.stage3_gdnet_pick": "last"})
        assert checkpoint.tree_equal(played.gdnet, own3.gdnet) and played.gdnet_source == "stage3 step 4"
    with pytest.raises(checkpoint.CheckpointError, match="'split' GDNets need stage 3's networks"):
        pipeline.load_vags(run, cfg, stage="stage2", gdnet="split")


def _saved_equal(saved: dict, tree) -> bool:
    """Arrays of a checkpoint part (``checkpoint.read``) equal the non-empty leaves of ``tree``."""
    leaves = [np.asarray(x) for x in jax.tree.leaves(tree) if np.size(x) > 0]
    return len(leaves) == len(saved) and all(
        x.dtype == saved[f"{i:05d}"].dtype and np.array_equal(x, saved[f"{i:05d}"]) for i, x in enumerate(leaves))


def test_pipeline_in_memory_gives_the_networks_train_py_wrote(runs, programs):
    """The pipeline as a fold of pure stage functions (``stages.pipeline.train_in_memory``:
    nothing written, the stages handing over in memory) gives, bit for bit, the networks that
    train.py wrote for the same config: stage 1's GDNet, stage 2's networks and threshold, and
    stage 3's GDNet, VANet, success net and re-set threshold."""
    full, _ = runs
    cfg = checkpoint.load_config(full)
    gg = pipeline.ggcnn_params(full, cfg)  # None: the "gdnet" close-view planner needs no GG-CNN
    h1, _ = fold.train_in_memory(cfg, None, names=("stage1",), handover=fold.Handover(ggcnn=gg), chunk=2,
                                 build=lambda name: programs.stage(name, cfg))
    assert checkpoint.tree_equal(h1.gdnet, pipeline.stage1_gdnet(full, cfg))
    h2, _ = fold.train_in_memory(cfg, None, names=("stage2",), handover=h1, chunk=2,
                                 build=lambda name: programs.stage(name, cfg))
    saved2, _ = checkpoint.read(pipeline.networks_dir(full, "stage2"))
    assert all(_saved_equal(saved2[part], tree) for part, tree in fold.networks_of(h2).items())
    h3, metrics = fold.train_in_memory(cfg, None, names=("stage3",), handover=h2, chunk=2,
                                       build=lambda name: programs.stage(name, cfg))
    saved3, _ = checkpoint.read(pipeline.networks_dir(full, "stage3"))
    assert all(_saved_equal(saved3[part], tree) for part, tree in fold.networks_of(h3).items())
    rows = _metrics(os.path.join(full, "stage3", "metrics.jsonl"))
    losses = np.concatenate([np.asarray(m["loss_vanet"]) for m in metrics["stage3"]])
    assert [r["loss_vanet"] for r in rows] == [float(x) for x in losses]


# The rounds of this file's evaluations end after 2 x objects attempts (the benchmark's budget
# without its 5 extra): the untrained networks rarely grasp, so most rounds play their whole
# budget, and every check below holds for any budget.
BUDGET = "benchmark.max_attempts_extra=0"


def _eval_py(argv, sets=()):
    """eval.py ``argv`` with ``--set BUDGET *sets`` in a new process (this session's compile
    cache: conftest) -> its stderr."""
    argv = argv + ["--set", BUDGET, *sets]
    proc = subprocess.run([sys.executable, os.path.join(ROOT, "eval.py")] + argv, cwd=ROOT, capture_output=True,
                          text=True)
    assert proc.returncode == 0, proc.stderr[-4000:]
    return proc.stderr


def test_eval_vags_sweep_csv_and_record(runs, tmp_path):
    """eval.py on the pipeline's run: the vags policy by default, its CSV, a threshold sweep
    whose extremes never / always move the camera, quantile thresholds taken from the scores
    the main run recorded, and --record pictures.  It runs in a new process, and a second
    eval.py process of the same groups and rounds compiles nothing (its programs come from the
    cache the first filled) and gives the same overall figures."""
    full, _ = runs
    out, rec = str(tmp_path / "vags.json"), str(tmp_path / "pictures")
    # One round per group: the benchmark, its sweep and --record (the first round of each
    # group) then all play the same 2 worlds, and --record reuses the benchmark's reset.
    err = _eval_py(["--run", full, "--groups", "1,2", "--rounds", "1", "--out", out,
                    "--threshold-sweep=-1000:1000:2000", "--quantile-sweep", "0:1:1", "--record", rec])
    assert "evaluating vags (" in err and "stage3 step 4" in err
    assert "direct grasps planned by GDNet's argmax (vags.direct_score='q'); grasps after a move by" in err
    with open(out) as f:
        report = json.load(f)
    assert report["policy"] == "vags" and report["networks"] == "stage3 step 4"
    assert report["planners"] == {"direct": "q", "after_move": report["config"]["vags"]["close_score"]}
    assert report["gdnet"] == _gate_table(full)["gdnet"]  # the GDNet the run kept
    with open(str(tmp_path / "vags.csv")) as f:
        assert len(f.read().strip().splitlines()) == 1 + 2 + 1  # header, 2 groups, overall
    with open(str(tmp_path / "vags_sweep.json")) as f:
        rows = json.load(f)["rows"]
    never, always, q0, q1 = rows
    assert (never["kind"], never["threshold"], always["threshold"]) == ("absolute", -1000, 1000)
    assert never["overall"]["viewpoint_rate"] == 0.0 and never["overall"]["motions"] == never["overall"]["attempts"]
    assert always["overall"]["viewpoint_rate"] == 1.0
    assert always["overall"]["motions"] == 2 * always["overall"]["attempts"]
    scores = [s for o in report["outcomes"].values() for row in o["scores"] for s in row if s == s]
    assert len(scores) == report["overall"]["attempts"]  # one decision value per attempt
    assert (q0["kind"], q0["quantile"], q1["quantile"]) == ("quantile", 0, 1)
    assert q0["threshold"] == pytest.approx(min(scores)) and q1["threshold"] == pytest.approx(max(scores))
    pngs = [f for _, _, fs in os.walk(rec) for f in fs if f.endswith(".png")]
    rounds_json = [os.path.join(r, f) for r, _, fs in os.walk(rec) for f in fs if f.endswith(".json")]
    assert len(rounds_json) == 2 and pngs  # the first round of each group
    with open(rounds_json[0]) as f:
        attempts = json.load(f)["attempts"]
    assert attempts and all(a["direct"] in (True, False) and a["success"] in (True, False) for a in attempts)
    # Both evaluations run in new processes: in this one the text of a program depends on what it
    # traced before (the pipeline and its gate table; bench/RESULTS.md, "Compile cache").
    path = str(tmp_path / "second.json")
    _eval_py(["--run", full, "--groups", "1,2", "--rounds", "1", "--out", path])
    with open(path) as f:
        again = json.load(f)
    assert again["compile"]["compiled"] == 0 and again["compile"]["loaded"] > 0, again["compile"]
    assert again["overall"] == report["overall"]


def _gate_table(run):
    with open(os.path.join(run, "gate.json")) as f:
        t = json.load(f)
    return {k: v for k, v in t.items() if k not in ("wall_s", "device")}


def test_the_pipeline_measures_the_rate_gate_table_that_eval_plays(runs, tmp_path, capsys):
    """train.py's pipeline ends by measuring the "rate" gate's table (``stages.gate_measure``;
    2 piles x the tiny preset's 2 attempts, 2 bins) into RUN/gate.json, for the
    networks stage 3 ended with: the run trained piece by piece measured it on stage 3's step 2,
    then again on step 4, and gets the uninterrupted run's table.  Its move values follow from
    its own figures at its rate; eval.py --set vags.gate=rate plays it and moves exactly where
    those values say."""
    full, split = runs
    t = _gate_table(full)
    assert t == _gate_table(split)
    assert [r["from"] for r in _timings(full) if r["stage"] == "gate"] == [0]
    assert len([r for r in _timings(split) if r["stage"] == "gate"]) == 2  # after stage 3 alone, after its resume
    assert t["networks"] == "stage3 step 4" and (t["worlds"], t["steps"], len(t["states"])) == (2, 2, 2)
    assert 0 < t["live_states"] == sum(t["states"]) <= 4
    for direct, moved, extra, value in zip(t["direct"], t["moved"], t["extra_seconds"], t["move_value"]):
        assert 0 <= direct <= 1 and 0 <= moved <= 1
        assert value == pytest.approx(moved - direct - t["rate"] * extra)
    # The per-state rows it was fit on (RUN/gate_states.npz) refit to the same table; objects
    # knocked off are counts, never negative; every live state had 1..max_objects on the table.
    rows = np.load(os.path.join(full, "gate_states.npz"))
    assert rows["p_direct"].shape == rows["objects"].shape == (t["live_states"],)
    assert ((rows["direct_lost"] >= 0) & (rows["moved_lost"] >= 0)).all()
    assert ((rows["objects"] >= 1) & (rows["objects"] <= t["objects"][1])).all()
    # Every success estimate is recorded beside the one the table bins (the run's, "grasp"); the
    # success net's largest value anywhere is at least its value at GDNet's grasp.
    assert t["estimate"] == "grasp" and t["close_score"] == "q"  # as the run's config scores grasps after a move
    np.testing.assert_array_equal(rows["p_grasp"], rows["p_direct"])
    assert all(rows[k].shape == rows["p_direct"].shape for k in ("p_symmetric", "p_window", "p_best", "q_direct"))
    assert (rows["p_best"] >= rows["p_grasp"]).all()
    refit = rate_gate.fit(rows["p_direct"], rows["direct_success"], rows["direct_seconds"], rows["moved_success"],
                          rows["moved_seconds"], 2, lost_direct=rows["direct_lost"], lost_moved=rows["moved_lost"])
    assert refit.move_value == pytest.approx(tuple(t["move_value"])) and refit.lost_moved == pytest.approx(tuple(t["lost_moved"]))
    assert refit.move_value_se == pytest.approx(tuple(t["move_value_se"]))  # gate.json records each bin's error
    out = str(tmp_path / "rate.json")
    # In a new process, as the sweep-and-record test's: its reset of 2 worlds is then the program
    # that test's first eval.py compiled and the cache holds (in this process, after the pipeline,
    # the same reset lowers to other text and compiles again: bench/RESULTS.md, "Compile cache").
    _eval_py(["--run", full, "--groups", "1", "--rounds", "2", "--out", out], sets=["vags.gate=rate"])
    with open(out) as f:
        report = json.load(f)
    assert report["threshold"] == 0.0 and report["overall"]["attempts"] > 0
    if all(v > 0 for v in t["move_value"]):
        assert report["overall"]["viewpoint_rate"] == 1.0
    if all(v <= 0 for v in t["move_value"]):  # a move worth 0 is not made either
        assert report["overall"]["viewpoint_rate"] == 0.0
    # The report says where the gate moved and what its table predicted (no cap given).
    assert report["rate_gate"]["moving_bins"] == [k for k, v in enumerate(t["move_value"]) if v > 0]
    assert report["rate_gate"]["bins"] == 2 and report["rate_gate"]["max_motion_number"] == 0.0
    assert report["rate_gate"]["estimate"] == "grasp"  # the success estimate its table bins
    assert report["rate_gate"]["close_score"] == "q"
    assert report["rate_gate"]["close_bins"] == rate_gate.close_bins(refit)  # the bins decided within noise
    # vags.max_motion_number reaches the decision's table through the run's networks: a cap of 1
    # (every grasp at its first motion) leaves no bin moving.
    cfg = checkpoint.load_config(full)
    capped = pipeline.load_vags(full, C.replace(cfg, **{"vags.max_motion_number": 1.0})).gate_table
    assert capped is not None and (np.asarray(capped)[1] <= 0).all()
    score = decision.gate_score("rate", None, jnp.linspace(-1.0, 2.0, 7), None, gate_table=jnp.asarray(capped))
    assert bool((score > 0).all())  # the decision grasps directly in every bin
    np.testing.assert_allclose(pipeline.load_vags(full, cfg).gate_table[1], t["move_value"], rtol=1e-6)


def test_the_gate_measure_can_follow_the_moves(runs, programs):
    """``gate_measure.measure(follow="moved")`` (``--follow moved``, a diagnostic of rounds that
    always move): the piles go on from the grasp after a move instead of the direct one.  From the
    same first piles, the first attempt's rows are the same either way; at the next attempt each
    pile holds the objects the branch it followed left, and the piles differ (the two grasps
    disturbed them differently), so the second attempt's estimates differ somewhere."""
    steps = 2
    rows = {f: gate_measure.measure(runs[0], steps=steps, seed=17, log=lambda m: None, programs=programs,
                                    gdnet="stage2", follow=f)[2]
            for f in gate_measure.FOLLOW}
    first = [{k: v[r["attempt"] == 0] for k, v in r.items()} for r in rows.values()]
    for k in first[0]:
        np.testing.assert_array_equal(first[0][k], first[1][k], err_msg=k)
    for f, r in rows.items():
        for w in np.unique(r["world"]):
            i, j = (np.flatnonzero((r["world"] == w) & (r["attempt"] == a)) for a in (0, 1))
            if i.size and j.size:
                taken = int(r[f"{f}_success"][i[0]]) + int(r[f"{f}_lost"][i[0]])
                assert r["objects"][j[0]] == r["objects"][i[0]] - taken, (f, w)
    second = {f: {int(w): r["p_direct"][(r["world"] == w) & (r["attempt"] == 1)]
                  for w in np.unique(r["world"])} for f, r in rows.items()}
    differ = False
    for w, p in second["direct"].items():
        q = second["moved"].get(w, np.zeros(0))
        differ |= p.size != q.size or (p.size > 0 and not np.array_equal(p, q))
    assert differ, "the two follows gave the same second attempts: the piles did not follow the branch"


def test_the_gate_measure_with_success_planned_direct_grasps_also_grasps_at_gdnets_argmax(runs, programs):
    """``--direct-score success``: the table's direct grasp is the success net's half-turn-mean
    argmax, recorded in its meta, and its states also hold GDNet's direct grasp from the same
    state ("gdnet" branch).  From the same first piles, that branch is the "q" table's direct
    grasp, and the planned grasp's half-turn mean (``p_symmetric``) is never below GDNet's; the two
    planners choose other grasps somewhere."""
    kw = dict(steps=2, seed=0, log=lambda m: None, programs=programs, gdnet="stage3")
    _, meta_q, q = gate_measure.measure(runs[0], **kw)
    _, meta_s, s = gate_measure.measure(runs[0], direct_score="success", **kw)
    assert (meta_q["direct_score"], meta_s["direct_score"]) == ("q", "success")
    assert "gdnet_success" not in q
    first_q, first_s = ({k: v[r["attempt"] == 0] for k, v in r.items()} for r in (q, s))
    np.testing.assert_array_equal(first_s["world"], first_q["world"])
    for k in ("success", "lost", "seconds"):
        np.testing.assert_array_equal(first_s[f"gdnet_{k}"], first_q[f"direct_{k}"], err_msg=k)
    assert (first_s["p_symmetric"] >= first_q["p_symmetric"] - 1e-6).all()
    # The barely trained nets' argmaxes differ somewhere (which states depends on the CPU's rounding):
    # a higher half-turn mean on a first pile, or another grasp (another time) on any state of the table.
    assert ((first_s["p_symmetric"] > first_q["p_symmetric"] + 1e-6).any()
            or (s["direct_seconds"] != s["gdnet_seconds"]).any())
    assert s["gdnet_success"].shape == s["direct_success"].shape == s["p_direct"].shape


def test_metrics_are_sane(runs):
    rows = _metrics(os.path.join(runs[0], "metrics.jsonl"))
    for r in rows:
        assert set(METRICS) <= set(r)
        assert 0.0 <= r["success_rate"] <= 1.0 and 0.0 <= r["explored"] <= 1.0
        assert r["physics_errors"] == 0 and r["buffer_overflow"] == 0
    for r in rows:  # every world either grasps (one transition) or starts a new round
        assert r["attempts"] + r["worlds_resetting"] == 2
    assert rows[-1]["attempts_total"] == sum(r["attempts"] for r in rows) == rows[-1]["grasp_attempts"]
    assert rows[-1]["replay_size"] == rows[-1]["attempts_total"]  # one transition per attempt
    assert rows[-1]["updates"] == 1  # learning started once replay held learning_starts


def test_resume_errors(tmp_path, capsys, programs):
    assert train.main(["--out", str(tmp_path / "nope"), "--resume"], programs) == 2
    assert "does not exist; drop --resume" in capsys.readouterr().err


def test_refuses_to_overwrite_a_run(runs, capsys, programs):
    assert train.main(["--config", "tiny", "--out", runs[0]], programs) == 2
    assert "already holds a run (checkpoint 4); pass --resume" in capsys.readouterr().err


def _files(path):
    out = {}
    for root, _, names in os.walk(path):
        for n in names:
            with open(os.path.join(root, n), "rb") as f:
                out[os.path.relpath(os.path.join(root, n), path)] = f.read()
    return out


def test_resume_with_iterations_already_done_changes_nothing(runs, capsys, programs):
    """A run at 4: asking for 2 is an error, asking for 4 (or a plain --resume) has nothing to
    do; neither trains nor rewrites config.json (which would stall later resumes)."""
    before = _files(runs[0])
    assert train.main(["--out", runs[0], "--resume", "--stage", "gdnet", "--quiet", "--set", "stage1.iterations=2"], programs) == 2
    assert "already at iteration 4: the requested stage1.iterations=2 are already done" in capsys.readouterr().err
    assert train.main(["--out", runs[0], "--resume", "--stage", "gdnet", "--quiet"], programs) == 0
    assert "already at iteration 4 of 4: nothing to train (config.json unchanged)" in capsys.readouterr().err
    # The whole pipeline is done too: --resume trains nothing and changes nothing.
    assert train.main(["--out", runs[0], "--resume", "--quiet"], programs) == 0
    said = capsys.readouterr()
    assert said.out == "" and f"{runs[0]} is already trained (stage1 4/4, stage2 2/2, stage3 4/4): nothing to " \
        f"train; evaluate it with python eval.py --run {runs[0]}" in said.err
    # Stage 1 has been built on: its iterations can no longer change.
    assert train.main(["--out", runs[0], "--resume", "--quiet", "--set", "stage1.iterations=6"], programs) == 2
    assert "already started from the end of stage 1: GDNet" in capsys.readouterr().err
    assert _files(runs[0]) == before


def _cut(paths):
    for p in paths:
        with open(p, "r+b") as f:
            f.truncate(os.path.getsize(p) // 2)


def test_damaged_checkpoint_is_named_before_compiling(runs, tmp_path, capsys):
    """The latest checkpoint's largest file cut in half (a partial copy): train.py --resume,
    which reads it all, names the step directory and the fallback, in one line (tests/test_bad_inputs.py checks
    that such refusals compile nothing).
    eval.py reads only the learner, which may lie in other files: with every data file cut it
    says the same."""
    run = str(tmp_path / "run")
    shutil.copytree(runs[0], run)
    step_dir = os.path.join(run, "checkpoints", "4")
    files = [os.path.join(r, f) for r, _, fs in os.walk(step_dir) for f in fs]
    _cut([max(files, key=os.path.getsize)])
    shutil.rmtree(os.path.join(run, "stage2"))
    shutil.rmtree(os.path.join(run, "stage3"))
    train_argv = ["--out", run, "--resume", "--stage", "gdnet", "--quiet", "--set", "stage1.iterations=6"]
    eval_argv = ["--run", run, "--groups", "1-2", "--rounds", "2"]
    for main, argv in ((train.main, train_argv), (_cut_all_then(eval_cli.main, step_dir), eval_argv)):
        assert main(argv) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "Traceback" not in err[0], err
        assert f"checkpoint 4 in {run} is damaged or incomplete" in err[0]
        assert f"delete {step_dir} to go back to checkpoint 2" in err[0]


def _cut_all_then(main, step_dir):
    def run(argv):
        data = os.path.join(step_dir, "default", "ocdbt.process_0", "d")
        _cut([os.path.join(data, f) for f in os.listdir(data)])
        return main(argv)

    return run


def test_divergence_stops_and_keeps_the_last_good_checkpoint(runs, target, tmp_path, capsys, monkeypatch, programs):
    """A NaN loss in the second chunk (injected into the metrics the host checks): exit code 1,
    a message naming the iteration, and the state before that chunk saved as the checkpoint
    (equal to the uninterrupted run's checkpoint 2), nothing after it."""
    real_run = Stage1.run

    def poisoned(self, state, n):
        state, m = real_run(self, state, n)
        if int(state.iteration) == 4:
            m = dict(m, loss=m["loss"].at[1].set(jnp.nan))
        return state, m

    monkeypatch.setattr(Stage1, "run", poisoned)
    out = str(tmp_path / "diverged")
    code = train.main(["--config", "tiny", "--stage", "gdnet", "--chunk", "2", "--checkpoint-every", "2", "--quiet",
                       "--out", out, "--set"] + _overrides(6), programs)
    err = capsys.readouterr().err
    assert code == 1
    assert "loss became non-finite at iteration 3" in err and "last good checkpoint is iteration 2" in err
    assert checkpoint.checkpoint_steps(out) == [2]
    saved, _ = checkpoint.restore(out, target)
    good, _ = checkpoint.restore(runs[0], target, step=2)
    assert int(saved.iteration) == 2 and checkpoint.tree_equal(saved, good)


def test_ctrl_c_stops_at_a_chunk_boundary_and_resume_matches(runs, target, tmp_path, programs):
    """Ctrl-C sent to a stage-1 training (a subprocess, this session's compile cache: conftest) once
    its first metrics rows are written: the chunk in flight finishes and is checkpointed, one
    line says where it stopped, exit code 130, the segment is in timings.jsonl; --resume to 4
    iterations then equals the uninterrupted run's stage 1, checkpoint and metrics."""
    out = str(tmp_path / "interrupted")
    argv = [sys.executable, "train.py", "--config", "tiny", "--stage", "gdnet", "--chunk", "2", "--quiet",
            "--out", out, "--set"] + _overrides(40)  # far more than it can run before the signal lands
    proc = subprocess.Popen(argv, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    metrics_path = os.path.join(out, "metrics.jsonl")
    while proc.poll() is None and not (os.path.exists(metrics_path) and os.path.getsize(metrics_path)):
        time.sleep(0.02)
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=600)
    assert proc.returncode == 130, stderr
    assert "Traceback" not in stderr and stdout == ""
    last = stderr.strip().splitlines()[-1]
    stopped = re.fullmatch(r"interrupted at stage1 iteration (\d+); --resume continues", last)
    assert stopped, stderr
    it = int(stopped.group(1))
    assert it in (2, 4) and checkpoint.checkpoint_steps(out)[-1] == it
    with open(os.path.join(out, "timings.jsonl")) as f:
        seg = [json.loads(l) for l in f]
    assert [(s["stage"], s["from"], s["to"], s["status"]) for s in seg] == [("stage1", 0, it, "interrupted")]
    if it < 4:
        assert train.main(["--out", out, "--resume", "--stage", "gdnet", "--chunk", "2", "--quiet", "--set",
                           "stage1.iterations=4"], programs) == 0
    a, _ = checkpoint.restore(out, target, step=4)
    b, _ = checkpoint.restore(runs[0], target, step=4)
    assert checkpoint.tree_equal(a, b), "the interrupted and resumed run diverged from the uninterrupted one"
    assert _metrics(metrics_path)[:4] == _metrics(os.path.join(runs[0], "metrics.jsonl"))


def test_bad_override_is_a_clear_error(tmp_path, capsys, programs):
    assert train.main(["--config", "tiny", "--out", str(tmp_path / "x"), "--set", "dqn.gama=0.3"], programs) == 2
    assert "gama" in capsys.readouterr().err
    assert train.main(["--config", "tiny", "--out", str(tmp_path / "y"), "--set", "stage1.max_objects=7"], programs) == 2


def test_checkpoint_from_other_config_is_refused(runs, target):
    smaller = target.replace(replay=replay.init(32, jax.tree.map(lambda x: x[0], target.replay.data)))
    with pytest.raises(checkpoint.CheckpointError, match="different config"):
        checkpoint.restore(runs[0], smaller)
    with pytest.raises(checkpoint.CheckpointError, match="no checkpoint 99"):
        checkpoint.restore(runs[0], target, step=99)


def test_ggcnn_is_needed_only_by_its_planner_or_when_asked(tmp_path):
    """The pipeline trains GG-CNN for the "ggcnn" close-view planner or vags.train_ggcnn; a stage
    of a run that needs none starts without one, and one the run holds is still loaded."""
    cfg = C.replace(C.tiny(), **C.parse_overrides(_overrides(4)))
    run = str(tmp_path / "run")
    os.makedirs(run)
    assert not pipeline.needs_ggcnn(cfg) and pipeline.total(cfg, "ggcnn") == 0
    assert pipeline.ggcnn_params(run, cfg) is None
    for key, value in (("vags.local_planner", "ggcnn"), ("vags.train_ggcnn", True)):
        needing = C.replace(cfg, **{key: value})
        assert pipeline.needs_ggcnn(needing) and pipeline.total(needing, "ggcnn") == 1
        with pytest.raises(checkpoint.CheckpointError, match=r"stage 2 needs the end of GG-CNN .* --stage ggcnn"):
            pipeline.ggcnn_params(run, needing)
    _with_ggcnn(run)
    params = pipeline.ggcnn_params(run, cfg)
    assert jax.tree.leaves(params) and all(np.array_equal(a, b) for a, b in zip(
        jax.tree.leaves(params), jax.tree.leaves(ggcnn_stage.load_ggcnn(run)[0])))


def test_a_run_kit_loads_the_same_networks_and_gate_table(runs, tmp_path, capsys):
    """``bench/run_kit.py`` copies what eval.py loads of a run (config, gate table and its
    states, stages 2-3's networks at the steps the table names or each stage's latest; no
    stage-1 carry, replay or worlds): the kit loads the run's networks and table exactly, and a
    second kit into the same folder is refused in one line."""
    sys.path.insert(0, os.path.join(ROOT, "bench"))
    import run_kit

    full, _ = runs
    kit = str(tmp_path / "kit")
    assert run_kit.main(["--run", full, "--out", kit]) == 0
    got = json.loads(capsys.readouterr().out)
    assert got["steps"] == {"stage2": [checkpoint.checkpoint_steps(pipeline.networks_dir(full, "stage2"))[-1]],
                            "stage3": [4]}
    assert not os.path.exists(os.path.join(kit, checkpoint.CHECKPOINT_DIR))
    assert not os.path.exists(os.path.join(kit, "stage3", checkpoint.CHECKPOINT_DIR))  # stage 3's carry
    a, b = pipeline.load_vags(full), pipeline.load_vags(kit)
    assert (a.source, a.gdnet_source, a.close_source) == (b.source, b.gdnet_source, b.close_source)
    for name in ("gdnet", "vanet", "success", "calibration", "close_gdnet", "q_threshold"):
        x, y = getattr(a, name), getattr(b, name)
        assert (x is None and y is None) or checkpoint.tree_equal(x, y), name
    np.testing.assert_array_equal(np.asarray(a.gate_table), np.asarray(b.gate_table))
    assert run_kit.main(["--run", full, "--out", kit]) == 1
    assert "exists: give a new folder" in capsys.readouterr().err
