"""VPG's stage (vags_jax/stages/vpg.py) through train.py --stage vpg, resumed bit for bit, and
eval.py --policy vpg on its networks; the command lines' refusals."""
import json
import os

import numpy as np
import pytest

import eval as eval_cli
import train
from vags_jax.stages import checkpoint, vpg as vpg_stage

from conftest import FAST_PHYSICS

# The tiny preset shrunk as conftest's TINY_TEST_OVERRIDES, for VPG's stage, on conftest's
# FAST_PHYSICS (its chunk and eval compile about a third faster; no check here depends on the
# contacts); one iteration per chunk so that 2 + 1 iterations and 3 iterations run the same
# compiled chunk.
SETS = ["vpg.n_worlds=2", "vpg.max_objects=2", "vpg.learning_starts=2", "dqn.batch_size=4", "replay.capacity=64",
        *FAST_PHYSICS]


def _train(out, iterations, programs, resume=False):
    argv = ["--stage", "vpg", "--out", out, "--chunk", "1", "--quiet"]
    if resume:
        argv += ["--resume", "--set", f"vpg.iterations={iterations}"]
    else:
        argv += ["--config", "tiny", "--set", *SETS, f"vpg.iterations={iterations}"]
    assert train.main(argv, programs) == 0


@pytest.fixture(scope="module")
def runs(tmp_path_factory, programs):
    root = tmp_path_factory.mktemp("vpg")
    a, b = str(root / "a"), str(root / "b")
    _train(a, 2, programs)
    _train(a, 3, programs, resume=True)
    _train(b, 3, programs)
    return a, b


def test_train_vpg_writes_its_run_and_resumes_bit_for_bit(runs):
    a, b = runs
    d = vpg_stage.vpg_dir(a)
    assert checkpoint.checkpoint_steps(d)[-1] == 3
    assert checkpoint.load_config(d).vpg.iterations == 3
    rows = [json.loads(line) for line in open(os.path.join(d, "metrics.jsonl"))]
    assert [r["iteration"] for r in rows] == [0, 1, 2] and all(r["stage"] == "vpg" for r in rows)
    assert all(np.isfinite(r["loss"]) for r in rows)
    assert sum(r["attempts"] for r in rows) == rows[-1]["attempts_total"]
    assert not os.path.exists(os.path.join(a, "checkpoints"))  # stage 1's place is left alone
    _, va, _ = vpg_stage.load_vpg(a)
    _, vb, _ = vpg_stage.load_vpg(b)
    assert checkpoint.tree_equal(va, vb)  # 2 iterations + resume = 3 uninterrupted
    assert set(va["params"]) == {"push_net", "grasp_net"}


def test_eval_vpg_plays_pushes_and_grasps(runs, capsys):
    a, _ = runs
    out = os.path.join(a, "eval_vpg.json")
    assert eval_cli.main(["--run", a, "--policy", "vpg", "--groups", "1", "--rounds", "2", "--out", out]) == 0
    table = capsys.readouterr().out
    assert "| overall" in table.replace("**", "") or "overall" in table
    rep = json.load(open(out))
    o = rep["overall"]
    assert rep["policy"] == "vpg" and o["rounds"] == 2 and "pushes" in o
    # Every push and every grasp is one motion.
    assert o["motions"] == o["attempts"] + o["pushes"]
    assert o["attempts"] + o["pushes"] >= 1


def test_vpg_refusals(tmp_path, capsys):
    out = str(tmp_path / "none")
    assert train.main(["--stage", "vpg", "--out", out, "--resume"]) == 2
    assert "has no VPG checkpoint" in capsys.readouterr().err
    assert train.main(["--stage", "vpg", "--out", out, "--config", "tiny", "--set", "vpg.max_objects=9"]) == 2
    assert "vpg.max_objects (9) exceeds scene.max_objects" in capsys.readouterr().err
    assert eval_cli.main(["--policy", "vpg"]) == 2
    assert "needs --run" in capsys.readouterr().err
    os.makedirs(out)
    assert eval_cli.main(["--run", out, "--policy", "vpg"]) == 2
    assert "no VPG checkpoint" in capsys.readouterr().err
