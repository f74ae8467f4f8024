"""``gate_measure --refit``: the rate gate's table fitted again from RUN/gate_states.npz over other
bins, on hand-made states whose table is worked out by hand (no simulation, nothing compiled)."""
import json
import os

import numpy as np
import pytest

from vags_jax.policies import rate_gate
from vags_jax.stages import gate_measure

META = {"networks": "stage3 step 80", "gdnet": "stage2 step 80", "close_gdnet": "stage3 step 80", "worlds": 4,
        "steps": 2, "seed": 0, "live_states": 8}


def _run_with_states(tmp_path) -> str:
    """A run directory holding a one-bin gate.json and the 8 states it was fit on: p_direct 0.1 ..
    0.8; the four lowest fail directly and succeed after a move; of the four highest all succeed
    directly and three after a move; a direct attempt takes 10 s, one with a move 12 s."""
    run = str(tmp_path / "run")
    os.makedirs(run)
    states = {"p_direct": np.arange(1, 9) / 10.0,
              "direct_success": np.array([0, 0, 0, 0, 1, 1, 1, 1], np.float32),
              "moved_success": np.array([1, 1, 1, 1, 1, 1, 0, 1], np.float32),
              "direct_lost": np.zeros(8, np.float32), "moved_lost": np.zeros(8, np.float32),
              "direct_seconds": np.full(8, 10.0), "moved_seconds": np.full(8, 12.0),
              "objects": np.full(8, 5), "world": np.arange(8) % 4, "attempt": np.arange(8) // 4}
    gate_measure.save_all(run, rate_gate.fit(states["p_direct"], states["direct_success"], states["direct_seconds"],
                                             states["moved_success"], states["moved_seconds"], 1,
                                             states["direct_lost"], states["moved_lost"]), META, states)
    return run


def test_refit_bins_the_saved_states_again_and_keeps_the_networks(tmp_path, capsys):
    run = _run_with_states(tmp_path)
    assert len(rate_gate.read(run)["states"]) == 1
    assert gate_measure.main(["--run", run, "--refit", "--bins", "2"]) == 0
    d = rate_gate.read(run)
    # Two bins split at the median p (0.45): below it direct 0/4, after a move 4/4; above, 4/4 and 3/4.
    assert d["edges"] == pytest.approx([0.45])
    assert d["states"] == [4, 4]
    assert d["direct"] == pytest.approx([0.0, 1.0]) and d["moved"] == pytest.approx([1.0, 0.75])
    assert d["extra_seconds"] == pytest.approx([2.0, 2.0])
    # Best gate: move in the low bin only -> (4 + 4) picks in (4 x 12 + 4 x 10) s = 1/11 picks per second
    # (moving nowhere: 4/80; everywhere: 7/96).  Move values: success gain minus rate x 2 s.
    assert d["rate"] == pytest.approx(1 / 11, rel=1e-6)
    assert d["move_value"] == pytest.approx([1.0 - 2 / 11, -0.25 - 2 / 11], rel=1e-6)
    assert {k: d[k] for k in META} == META  # the networks it was measured on, so eval.py still loads it
    assert d["refit"] == {"bins": 2, "from_bins": 1, "from_estimate": "grasp"} and d["estimate"] == "grasp"
    assert rate_gate.load_table(run, META["networks"], META["gdnet"], META["close_gdnet"]) is not None
    assert rate_gate.close_score_of(run) == "q"  # a table from before the score was recorded


def test_refit_into_out_leaves_the_run_alone(tmp_path):
    run = _run_with_states(tmp_path)
    before = rate_gate.read(run)
    out = str(tmp_path / "finer")
    assert gate_measure.main(["--run", run, "--refit", "--bins", "4", "--out", out]) == 0
    assert rate_gate.read(run) == before
    got = rate_gate.read(out)
    assert got["states"] == [2, 2, 2, 2] and got["run"] == run


@pytest.mark.parametrize("argv, says", [
    (["--refit"], "takes --bins"),
    (["--refit", "--bins", "2", "--worlds", "8"], "takes --bins"),
    (["--refit", "--bins", "2", "--close-score", "success"], "takes --bins"),  # the states hold one score's grasps
    (["--refit", "--bins", "9"], "at least one state per bin"),
])
def test_refit_errors_say_what_to_fix(tmp_path, capsys, argv, says):
    run = _run_with_states(tmp_path)
    assert gate_measure.main(["--run", run] + argv) == 2
    assert says in capsys.readouterr().err


def test_refit_without_saved_states_names_the_measuring_command(tmp_path, capsys):
    run = _run_with_states(tmp_path)
    os.remove(os.path.join(run, gate_measure.STATES_FILE))
    assert gate_measure.main(["--run", run, "--refit", "--bins", "2"]) == 2
    err = capsys.readouterr().err
    assert "gate_states.npz" in err and f"--run {run}" in err
    with open(os.path.join(run, rate_gate.GATE_FILE)) as f:
        assert len(json.load(f)["states"]) == 1  # untouched


def test_refit_on_another_estimate_bins_that_column_and_records_it(tmp_path):
    """--estimate symmetric bins the states' p_symmetric (here the reverse order of p_direct), so
    the two bins hold other states than with p_direct; the saved states' p_direct becomes it."""
    run = _run_with_states(tmp_path)
    path = os.path.join(run, gate_measure.STATES_FILE)
    with np.load(path) as f:
        states = {k: f[k] for k in f.files}
    states["p_symmetric"] = 1.0 - states["p_direct"]  # the direct failures now rank highest
    np.savez(path, **states)
    assert gate_measure.main(["--run", run, "--refit", "--bins", "2", "--estimate", "symmetric"]) == 0
    d = rate_gate.read(run)
    assert d["estimate"] == "symmetric" and d["refit"]["from_estimate"] == "grasp"
    assert d["edges"] == pytest.approx([0.55])
    assert d["direct"] == pytest.approx([1.0, 0.0]) and d["moved"] == pytest.approx([0.75, 1.0])
    assert rate_gate.estimate_of(run) == "symmetric"
    with np.load(path) as f:
        np.testing.assert_array_equal(f["p_direct"], states["p_symmetric"])


def test_refit_on_an_estimate_the_states_lack_names_the_measuring_command(tmp_path, capsys):
    run = _run_with_states(tmp_path)  # states from before the other estimates were recorded
    assert gate_measure.main(["--run", run, "--refit", "--bins", "2", "--estimate", "window"]) == 2
    err = capsys.readouterr().err
    assert "no 'window' estimates" in err and f"--run {run} --estimate window" in err
