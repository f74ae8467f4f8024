"""bench/gate_estimates.py: AUROC, the lowest eighth and each estimate's table, on hand-made
states whose figures are worked out by hand."""
import json
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "bench"))
import gate_estimates  # noqa: E402


def test_auroc_counts_ties_as_half():
    assert gate_estimates.auroc([1, 2, 3, 4], [0, 0, 1, 1]) == 1.0
    assert gate_estimates.auroc([1, 1, 1, 1], [0, 1, 0, 1]) == 0.5
    # positives 2, 3 against negatives 1, 2: pairs 1 + 0.5 + 1 + 1 of 4
    assert gate_estimates.auroc([1, 2, 2, 3], [0, 1, 0, 1]) == pytest.approx(0.875)


def test_the_estimate_that_ranks_the_failures_lowest_is_picked(tmp_path, capsys):
    # 16 states: the 4 direct failures succeed after a move; the 12 successes also do.  A direct
    # attempt takes 10 s, one with a move 12 s.  p_symmetric ranks the 4 failures lowest; p_grasp
    # puts one in each of its 4 bins; p_window is one value, so one bin.
    direct = np.array([0, 0, 0, 0] + [1] * 12, np.float32)
    states = {"direct_success": direct, "moved_success": np.ones(16, np.float32),
              "direct_seconds": np.full(16, 10.0), "moved_seconds": np.full(16, 12.0),
              "p_symmetric": np.arange(16) / 16.0,  # failures lowest
              "p_grasp": np.r_[[0, 5, 10, 15], [1, 2, 3, 4, 6, 7, 8, 9, 11, 12, 13, 14]] / 16.0,
              "p_window": np.full(16, 0.5)}  # says nothing: one bin
    path = str(tmp_path / "gate_states.npz")
    np.savez(path, **states)
    assert gate_estimates.main([path, "--bins", "4", "--json", str(tmp_path / "r.json")]) == 0
    rep = json.load(open(tmp_path / "r.json"))
    sym, grasp = rep["columns"]["p_symmetric"], rep["columns"]["p_grasp"]
    # p_grasp: successes 1-4 beat one failure, 6-9 two, 11-14 three: 24 of 48 pairs.
    assert sym["auroc_direct"] == 1.0 and grasp["auroc_direct"] == 0.5
    # The lowest eighth (2 states) by p_symmetric: both direct failures, both succeed after a move:
    # +2 successes over 16 states.
    assert sym["lowest_eighth"] == {"states": 2, "direct": 0.0, "moved": 1.0, "gain_per_state": 0.125}
    # p_symmetric's table moves its lowest bin (the 4 failures): 16 picks in 4 x 12 + 12 x 10 = 168 s.
    assert sym["moving_bins"] == [0] and sym["picks_per_hour"] == pytest.approx(3600 * 16 / 168, abs=0.1)
    # p_grasp's bins each hold one failure: moving all of them is its best, 16 picks in 192 s.
    assert grasp["moving_bins"] == [0, 1, 2, 3] and grasp["picks_per_hour"] == pytest.approx(300.0, abs=0.1)
    assert rep["columns"]["p_window"]["bins"] == 1
    assert rep["pick"] == "symmetric"
    assert "pick: symmetric" in capsys.readouterr().out
