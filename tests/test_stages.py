"""Stage 1 end to end on CPU: train a few iterations, checkpoint, resume, compare bit for bit."""
import json
import os
import shutil
import time

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import eval as eval_cli
import train
from vags_jax import checkpoint, replay
from vags_jax.stages import METRICS, Stage1

from conftest import TINY_TEST_OVERRIDES


def _overrides(iterations):
    """train.py --set arguments giving the tiny_cfg fixture's config with `iterations`."""
    return [f"{k}={v}" for k, v in TINY_TEST_OVERRIDES.items()] + [f"stage1.iterations={iterations}"]


def _metrics(path):
    with open(path) as f:
        rows = [json.loads(l) for l in f]
    for r in rows:
        r.pop("wall_s")
    return rows


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """One uninterrupted 4-iteration run, and a 2-iteration run resumed to 4 iterations."""
    root = tmp_path_factory.mktemp("runs")
    full, split = str(root / "full"), str(root / "split")
    base = ["--config", "tiny", "--chunk", "2", "--quiet"]
    assert train.main(base + ["--out", full, "--set"] + _overrides(4)) == 0
    assert train.main(base + ["--out", split, "--set"] + _overrides(2)) == 0
    assert train.main(["--out", split, "--resume", "--chunk", "2", "--quiet", "--set", "stage1.iterations=4"]) == 0
    return full, split


@pytest.fixture(scope="module")
def target(runs):
    cfg = checkpoint.load_config(runs[0])
    return Stage1(cfg).init(jax.random.PRNGKey(cfg.seed))


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
    assert [r["iteration"] for r in ma] == [0, 1, 2, 3]
    assert ma == mb


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


def test_resume_errors(tmp_path, capsys):
    assert train.main(["--out", str(tmp_path / "nope"), "--resume"]) == 2
    assert "does not exist; drop --resume" in capsys.readouterr().err


def test_refuses_to_overwrite_a_run(runs, capsys):
    assert train.main(["--config", "tiny", "--out", runs[0]]) == 2
    assert "already holds a run (checkpoint 4); pass --resume" in capsys.readouterr().err


def _files(path):
    out = {}
    for root, _, names in os.walk(path):
        for n in names:
            with open(os.path.join(root, n), "rb") as f:
                out[os.path.relpath(os.path.join(root, n), path)] = f.read()
    return out


def test_resume_with_iterations_already_done_changes_nothing(runs, capsys):
    """A run at 4: asking for 2 is an error, asking for 4 (or a plain --resume) has nothing to
    do; neither trains nor rewrites config.json (which would stall later resumes)."""
    before = _files(runs[0])
    assert train.main(["--out", runs[0], "--resume", "--quiet", "--set", "stage1.iterations=2"]) == 2
    assert "already at iteration 4: the requested stage1.iterations=2 are already done" in capsys.readouterr().err
    assert train.main(["--out", runs[0], "--resume", "--quiet"]) == 0
    assert "already at iteration 4 of 4: nothing to train (config.json unchanged)" in capsys.readouterr().err
    assert _files(runs[0]) == before


def _cut(paths):
    for p in paths:
        with open(p, "r+b") as f:
            f.truncate(os.path.getsize(p) // 2)


def test_damaged_checkpoint_is_named_before_compiling(runs, tmp_path, capsys):
    """The latest checkpoint's largest file cut in half (a partial copy): train.py --resume,
    which reads it all, names the step directory and the fallback, in one line, in seconds.
    eval.py reads only the learner, which may lie in other files: with every data file cut it
    says the same."""
    run = str(tmp_path / "run")
    shutil.copytree(runs[0], run)
    step_dir = os.path.join(run, "checkpoints", "4")
    files = [os.path.join(r, f) for r, _, fs in os.walk(step_dir) for f in fs]
    _cut([max(files, key=os.path.getsize)])
    train_argv = ["--out", run, "--resume", "--quiet", "--set", "stage1.iterations=6"]
    eval_argv = ["--run", run, "--groups", "1-2", "--rounds", "2"]
    for main, argv in ((train.main, train_argv), (_cut_all_then(eval_cli.main, step_dir), eval_argv)):
        t = time.time()
        assert main(argv) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "Traceback" not in err[0], err
        assert f"checkpoint 4 in {run} is damaged or incomplete" in err[0]
        assert f"delete {step_dir} to go back to checkpoint 2" in err[0]
        assert time.time() - t < 30


def _cut_all_then(main, step_dir):
    def run(argv):
        data = os.path.join(step_dir, "default", "ocdbt.process_0", "d")
        _cut([os.path.join(data, f) for f in os.listdir(data)])
        return main(argv)

    return run


def test_divergence_stops_and_keeps_the_last_good_checkpoint(runs, target, tmp_path, capsys, monkeypatch):
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
    code = train.main(["--config", "tiny", "--chunk", "2", "--checkpoint-every", "2", "--quiet",
                       "--out", out, "--set"] + _overrides(6))
    err = capsys.readouterr().err
    assert code == 1
    assert "loss became non-finite at iteration 3" in err and "last good checkpoint is iteration 2" in err
    assert checkpoint.checkpoint_steps(out) == [2]
    saved, _ = checkpoint.restore(out, target)
    good, _ = checkpoint.restore(runs[0], target, step=2)
    assert int(saved.iteration) == 2 and checkpoint.tree_equal(saved, good)


def test_bad_override_is_a_clear_error(tmp_path, capsys):
    assert train.main(["--config", "tiny", "--out", str(tmp_path / "x"), "--set", "dqn.gama=0.3"]) == 2
    assert "gama" in capsys.readouterr().err
    assert train.main(["--config", "tiny", "--out", str(tmp_path / "y"), "--set", "stage1.max_objects=7"]) == 2


def test_checkpoint_from_other_config_is_refused(runs, target):
    smaller = target.replace(replay=replay.init(32, jax.tree.map(lambda x: x[0], target.replay.data)))
    with pytest.raises(checkpoint.CheckpointError, match="different config"):
        checkpoint.restore(runs[0], smaller)
    with pytest.raises(checkpoint.CheckpointError, match="no checkpoint 99"):
        checkpoint.restore(runs[0], target, step=99)
