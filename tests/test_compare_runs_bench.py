"""bench/compare_runs.py: two hand-made runs are equal bit for bit, and one changed element, a
changed metric or a missing checkpoint is named."""
import json
import os
import shutil
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "bench"))
from compare_runs import main  # noqa: E402

from vags_jax.stages import checkpoint  # noqa: E402


def _run(path, value=1.0, loss=0.5, wall=1.0):
    """A run with stage 1's checkpoint at the top and a stage-2 one below it, and metrics."""
    checkpoint.save(str(path), 2, {"learner": {"w": np.full((2, 3), value, np.float32)}, "step": np.int32(2)})
    checkpoint.save(str(path / "stage2"), 1, {"vanet": {"b": np.arange(4, dtype=np.float32)}})
    with open(path / "metrics.jsonl", "w") as f:
        f.write(json.dumps({"iteration": 0, "loss": loss, "wall_s": wall}) + "\n")
    return str(path)


def test_equal_runs_and_each_kind_of_difference(tmp_path, capsys):
    a = _run(tmp_path / "a")
    assert main([a, _run(tmp_path / "b", wall=7.0)]) == 0  # wall-clock seconds are not compared
    out = capsys.readouterr().out
    assert ".: steps [2] equal" in out and "stage2: steps [1] equal" in out and "3 arrays equal" in out
    assert main([a, _run(tmp_path / "c", value=1.0 + 2 ** -20)]) == 1
    assert "different: . step 2 learner leaf" in capsys.readouterr().out
    assert main([a, _run(tmp_path / "d", loss=0.25)]) == 1
    assert "different: metrics.jsonl differs" in capsys.readouterr().out
    e = _run(tmp_path / "e")
    shutil.rmtree(os.path.join(e, "stage2"))
    assert main([a, e]) == 1
    assert "checkpoint directories differ" in capsys.readouterr().out
    assert main([a]) == 2
