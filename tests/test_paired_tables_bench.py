"""bench/paired_tables.py: two hand-made measurements joined on (world, attempt), with the paired
difference, its standard error and the discordant pairs worked out by hand, a subset split, the
warning on diverged piles and the errors on a missing file or no match."""
import json
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "bench"))
import paired_tables  # noqa: E402

from vags_jax.policies import rate_gate  # noqa: E402

# A: 8 states, worlds 0-3, attempts 0-1.  p_direct's median splits 2 bins at 0.5; the low bin's
# direct grasps fail 3 of 4 and succeed 3 of 4 after a move (10 s direct, 12 s with a move), so
# A's table moves bin 0 (7 picks in 88 s beat 6 in 80 s) and keeps bin 1.
A = {"world": [0, 0, 1, 1, 2, 2, 3, 3], "attempt": [0, 1, 0, 1, 0, 1, 0, 1],
     "p_direct": [0.1, 0.2, 0.3, 0.4, 0.6, 0.7, 0.8, 0.9],
     "direct_success": [0, 0, 0, 1, 1, 1, 1, 1], "moved_success": [1, 1, 0, 1, 1, 0, 1, 1],
     "objects": [3, 2, 8, 7, 4, 3, 9, 8]}
# B: A's states 0-6 (its (3, 1) is missing) plus (9, 0), in another order; after a move
# [1, 0, 1, 1, 1, 1, 1] on A's states 0-6; one direct outcome (state 3) disagrees.  B's table
# moves its bin below 0.5 (direct 0 of 4, after a move 3 of 4) and keeps the one above (4 of 4,
# 3 of 4).
B_ORDER = [6, 5, 4, 3, 2, 1, 0]
B_MOVED = [1, 0, 1, 1, 1, 1, 1]


def _b(objects_shift=0):
    b = {k: [v[i] for i in B_ORDER] for k, v in A.items()}
    b["moved_success"] = [B_MOVED[i] for i in B_ORDER]
    b["direct_success"] = [1 - A["direct_success"][i] if i == 3 else A["direct_success"][i] for i in B_ORDER]
    b["objects"] = [o + objects_shift for o in b["objects"]]
    extra = {"world": 9, "attempt": 0, "p_direct": 0.95, "direct_success": 1, "moved_success": 0, "objects": 5}
    return {k: v + [extra[k]] for k, v in b.items()}


def _measured(path, rows, close_score):
    """A directory as gate_measure.save_all writes it: rate_gate.fit's table in gate.json, the rows
    in gate_states.npz."""
    os.makedirs(path)
    s = {k: np.asarray(v, np.float32 if k in ("p_direct", "direct_success", "moved_success") else np.int32)
         for k, v in rows.items()}
    n = s["world"].size
    s["direct_seconds"], s["moved_seconds"] = np.full(n, 10.0), np.full(n, 12.0)
    table = rate_gate.fit(s["p_direct"], s["direct_success"], s["direct_seconds"], s["moved_success"],
                          s["moved_seconds"], 2)
    np.savez(os.path.join(path, paired_tables.STATES_FILE), **s)
    rate_gate.save(str(path), table, {"close_score": close_score})
    return str(path), table


def test_paired_difference_se_and_discordant_pairs(tmp_path, capsys):
    a, table_a = _measured(tmp_path / "a", A, "q")
    b, table_b = _measured(tmp_path / "b", _b(), "success")
    assert paired_tables.main([a, b, "--names", "q", "success", "--json", str(tmp_path / "r.json")]) == 0
    out = capsys.readouterr().out
    with open(tmp_path / "r.json") as f:
        rep = json.load(f)
    assert rep["states"] == [8, 8] and rep["matched"] == 7
    assert rep["objects_agree"] == 1.0 and rep["direct_agree"] == pytest.approx(6 / 7, abs=1e-4)
    assert "warning" not in out
    # B - A on the 7 matched: [0, -1, 1, 0, 0, 1, 0]: mean 1/7, variance (3 - 1/7) / 6.
    s = rep["subsets"]["all"]
    assert s["n"] == 7 and s["moved_a"] == pytest.approx(500 / 7, abs=1e-3)
    assert s["moved_b"] == pytest.approx(600 / 7, abs=1e-3)
    assert s["difference"] == pytest.approx(100 / 7, abs=1e-3)
    assert s["se"] == pytest.approx(100 * np.sqrt((3 - 1 / 7) / 6 / 7), abs=1e-3)
    assert (s["a_only"], s["b_only"]) == (1, 2)
    # A moves bin 0 (p < 0.5): states 0-3, B - A [0, -1, 1, 0]; it keeps 4-6, B - A [0, 1, 0].
    assert table_a.edges == pytest.approx((0.5,)) and list(np.asarray(table_a.move_value) > 0) == [True, False]
    mv, kept = rep["subsets"]["a_moving"], rep["subsets"]["a_kept"]
    assert (mv["n"], mv["difference"], mv["a_only"], mv["b_only"]) == (4, 0.0, 1, 1)
    assert mv["se"] == pytest.approx(100 * np.sqrt(2 / 3 / 4), abs=1e-3) and mv["direct"] == 25.0
    assert (kept["n"], kept["a_only"], kept["b_only"]) == (3, 0, 1)
    assert kept["difference"] == pytest.approx(100 / 3, abs=1e-3)
    # objects 3, 2, 8, 7, 4, 3, 9: 1-5 on states 0, 1, 4, 5.
    assert rep["subsets"]["objects_1_5"]["n"] == 4 and rep["subsets"]["objects_6_up"]["n"] == 3
    assert rep["subsets"]["objects_1_5"]["difference"] == 0.0  # [0, -1, 0, 1]
    # B's moving bins as rate_gate.paired_lost finds them on the matched states.
    p_b = np.asarray(A["p_direct"][:7])
    want = rate_gate.paired_lost(table_b, p_b, np.zeros(7), np.zeros(7))["moved_bins"]["states"]
    assert rep["subsets"]["b_moving"]["n"] == want == 4
    # The tables' own figures: A picks 7 in 88 s and predicts (4 x 2 + 4) motions for 7 picks.
    ta = rep["tables"][0]
    assert ta["picks_per_hour"] == pytest.approx(3600 * 7 / 88, abs=0.1) and ta["moving_bins"] == [0]
    assert ta["motion_number"] == pytest.approx(12 / 7, abs=1e-4) and ta["close_score"] == "q"
    assert "| success's moving bins |" in out and "| q's kept bins | 3 |" in out


def test_diverged_piles_warn(tmp_path, capsys):
    a, _ = _measured(tmp_path / "a", A, "q")
    b, _ = _measured(tmp_path / "b", _b(objects_shift=1), "success")
    rep = paired_tables.report(a, b)
    assert rep["objects_agree"] == 0.0
    paired_tables.print_report(rep)
    assert "**warning**: objects agree on under 90 %" in capsys.readouterr().out


def test_missing_file_and_no_match_are_named(tmp_path):
    a, _ = _measured(tmp_path / "a", A, "q")
    b, _ = _measured(tmp_path / "b", _b(), "success")
    os.remove(os.path.join(b, "gate_states.npz"))
    with pytest.raises(SystemExit, match="gate_states.npz.*vags_jax.stages.gate_measure"):
        paired_tables.main([a, b])
    os.remove(os.path.join(a, "gate.json"))
    with pytest.raises(SystemExit, match="gate.json.*--out"):
        paired_tables.main([a, b])
    far = dict(A, world=[w + 100 for w in A["world"]])
    c, _ = _measured(tmp_path / "c", far, "q")
    a2, _ = _measured(tmp_path / "a2", A, "q")
    with pytest.raises(SystemExit, match="no state"):
        paired_tables.report(a2, c)
