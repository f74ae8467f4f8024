"""Stage 1 end to end on CPU: train a few iterations, checkpoint, resume, compare bit for bit."""
import json
import os

import jax
import numpy as np
import pytest

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
    assert "config.json" in capsys.readouterr().err


def test_refuses_to_overwrite_a_run(runs):
    with pytest.raises(SystemExit, match="--resume"):
        train.main(["--config", "tiny", "--out", runs[0]])


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
