"""bench/gate_headroom.py's figures on hand-made states: each branch's success split by the gate's
decision and by object count, paired differences, the estimates' AUROC, the agreement check."""
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "bench"))
from gate_headroom import agreement, summarize, table  # noqa: E402


def _states():
    # Six states: 1, 1, 3, 3, 7, 7 objects; the gate moves at states 1, 3 and 5.
    return {"objects": np.array([1, 1, 3, 3, 7, 7]),
            "direct_success": np.array([1, 0, 1, 0, 1, 0], bool),
            "moved_success": np.array([1, 1, 1, 1, 0, 1], bool),
            "random_success": np.array([0, 1, 0, 0, 0, 0], bool),
            "oracle_success": np.array([1, 1, 1, 1, 1, 1], bool),
            "planned_success": np.array([1, 0, 1, 1, 1, 0], bool),
            "p_direct": np.array([0.9, 0.2, 0.8, 0.3, 0.7, 0.1]),
            "q_direct": np.array([0.1, 0.9, 0.5, 0.5, 0.2, 0.8])}


MOVES = np.array([0, 1, 0, 1, 0, 1], bool)


def test_branches_split_by_the_gates_decision_and_object_count():
    s = summarize(_states(), MOVES)
    everything = s["all"]["all"]
    assert everything["states"] == 6
    assert everything["direct"] == pytest.approx(0.5) and everything["moved"] == pytest.approx(5 / 6)
    assert everything["oracle"] == 1.0 and everything["random"] == pytest.approx(1 / 6)
    assert "gdnet" not in everything  # a branch the states do not hold is left out
    move = s["gate: move"]["all"]  # states 1, 3, 5: direct fails on all three, a move wins all three
    assert move["states"] == 3 and move["direct"] == 0.0 and move["moved"] == 1.0
    assert move["moved - direct"]["difference"] == 1.0 and move["moved - direct"]["se"] == 0.0
    assert move["moved - random"]["difference"] == pytest.approx(2 / 3)
    assert move["planned"] == pytest.approx(1 / 3) and move["moved - planned"]["difference"] == pytest.approx(2 / 3)
    direct = s["gate: direct"]["6-10"]  # state 4 alone: one state has no standard error
    assert direct["states"] == 1 and direct["moved - direct"] == {"difference": -1.0, "se": None}
    assert s["gate: move"]["1"]["states"] == 1 and s["gate: direct"]["2-5"]["states"] == 1


def test_auroc_of_the_gate_estimate_and_of_gdnets_q():
    everything = summarize(_states(), MOVES)["all"]["all"]
    assert everything["auroc_p_direct"] == 1.0  # every success has a higher p_direct than every failure
    # q_direct: successes 0.1, 0.5, 0.2 against failures 0.9, 0.5, 0.8: only the 0.5 tie, counted half.
    assert everything["auroc_q_direct"] == pytest.approx(0.5 / 9)
    assert summarize(_states(), MOVES)["gate: move"]["all"]["auroc_p_direct"] is None  # no success there


def test_table_rows_and_agreement():
    text = table(summarize(_states(), MOVES))
    assert ("| gate: move | all | 3 | 0.0 | 100.0 | 33.3 | 100.0 | 33.3 | +100.0 ± 0.0 | +100.0 ± 0.0 | +66.7 ± 33.3 "
            "| +66.7 ± 33.3 |") in text
    assert "| gate: direct | 6-10 | 1 |" in text and "| -100.0 |" in text  # no ± with one state
    assert "| gate: move | 6-10 | 1 |" in text
    s = _states()
    recorded = {"direct_success": s["direct_success"].copy(), "moved_success": s["moved_success"].copy()}
    recorded["moved_success"][0] = False
    assert agreement(s, recorded) == {"direct": 1.0, "moved": pytest.approx(5 / 6)}
    assert agreement(s, None) is None
    assert agreement(s, {"direct_success": np.zeros(4, bool), "moved_success": np.zeros(4, bool)}) is None


def test_collect_refuses_an_unknown_branch():
    from vags_jax import config as C
    from vags_jax.stages import gate_measure

    with pytest.raises(ValueError, match="extra branches must be among"):
        gate_measure.make_collect(C.tiny(), None, None, extra=("oracle", "nearest"))


def test_a_run_without_a_gate_table_is_one_line_and_exit_2(tmp_path, capsys):
    """Before compiling anything: a run without RUN/gate.json names the command that measures it;
    a folder that is no run says so."""
    from gate_headroom import main

    from vags_jax import config as C
    from vags_jax.stages import checkpoint

    checkpoint.save_config(str(tmp_path), C.tiny())
    assert main(["--run", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "has no gate table" in err[0] and "gate_measure --run" in err[0]
    assert main(["--run", str(tmp_path / "missing")]) == 2
    assert "does not exist" in capsys.readouterr().err
