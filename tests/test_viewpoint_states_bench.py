"""bench/viewpoint_states.py's AUROC, on hand-counted cases (the gate's ranking figure)."""
import os
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "bench"))
from viewpoint_states import auroc  # noqa: E402


def test_auroc_hand_cases():
    assert auroc([0.9, 0.8, 0.1, 0.2], [1, 1, 0, 0]) == 1.0  # every positive above every negative
    assert auroc([0.1, 0.2, 0.9, 0.8], [1, 1, 0, 0]) == 0.0
    assert auroc([0.5, 0.5, 0.5], [1, 0, 0]) == 0.5  # all tied
    # Positives 0.9 and 0.4, negatives 0.5 and 0.1: pairs won 2 (0.9) + 1 (0.4 > 0.1) of 4.
    assert auroc([0.9, 0.4, 0.5, 0.1], [1, 1, 0, 0]) == pytest.approx(0.75)
    # A tie between a positive and a negative counts half: (1 + 0.5) / 2.
    assert auroc([0.7, 0.3, 0.3], [1, 1, 0]) == pytest.approx(0.75)
    assert auroc([0.1, 0.2], [1, 1]) is None


def test_viewpoint_rows_ranks_moves_by_calibrated_p_direct(tmp_path):
    """bench/viewpoint_rows.py on 4 hand-made states: the lowest calibrated p_direct moves first,
    dead states are dropped, and paired counts are the states where only one branch succeeds."""
    import json

    import numpy as np
    from viewpoint_rows import load, paired_table, ranked_moves_table

    rows = {"live": np.array([1, 1, 1, 1, 0], bool),
            "p_direct": np.array([0.9, 0.2, 0.6, 0.4, 0.0], np.float32),
            "direct": np.array([1, 0, 1, 0, 1], bool),
            "view_gdnet": np.array([0, 1, 1, 0, 0], bool),
            "grasp_gdnet": np.array([1, 1, 1, 1, 0], bool),
            "relook_direct": np.array([1, 0, 1, 1, 0], bool),
            "random_gdnet": np.array([0, 0, 0, 0, 0], bool)}
    np.savez(tmp_path / "s.npz", **rows)
    (tmp_path / "s.json").write_text(json.dumps({"calibration": [0.1, 0.0, 0.7]}))
    loaded, cal = load(str(tmp_path / "s.npz"))
    assert loaded["direct"].shape == (4,) and cal == [0.1, 0.0, 0.7]
    table = paired_table(loaded)
    # view vs direct: 50 % each; only view succeeds on state 1, only direct on state 0.
    assert "| view_gdnet | direct | 50.0 | 50.0 | +0.0 | 1 | 1 |" in table
    assert "| grasp_gdnet | direct | 100.0 | 50.0 | +50.0 | 2 | 0 |" in table
    moves = ranked_moves_table(loaded, cal).splitlines()
    # Nothing moves at share 0: every branch column is the direct success, 50 %.
    assert moves[2].startswith("| 0.00 | - | 50.0 | 50.0 | 50.0 |")
    # Calibrated p_direct is [0.8, 0.1, 0.5, 0.3]: at the quantiles 0.05-0.3 only state 1 (0.1)
    # moves (share 0.25); VANet's view and the grasp cell succeed there, a second look does not,
    # so 3 of 4 succeed and the move adds 1.0.
    row = [r for r in moves if r.startswith("| 0.25 |")]
    assert row and "| 75.0 | 75.0 | 50.0 | +1.000 |" in row[0]


def test_viewpoint_states_refuses_an_unusable_cache_dir(tmp_path, capsys):
    """--cache-dir as in train.py and eval.py: an unusable directory ends with one line and exit 2,
    before any run is read."""
    from viewpoint_states import main

    blocker = tmp_path / "file"
    blocker.write_text("")
    assert main(["--run", str(tmp_path / "no_run"), "--cache-dir", str(blocker / "cc")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--cache-dir" in err[0] and "writable directory" in err[0]


def test_view_footprint_counts_the_pile_each_close_view_saw():
    """Two hand-made worlds: the share of object cells each close view saw, and whether VANet's
    and the random view's grasps are the same one (one rotation, within SAME_GRASP_CELLS)."""
    import jax.numpy as jnp
    import numpy as np
    from viewpoint_states import SAME_GRASP_CELLS, summarize, view_footprint

    from vags_jax.policies.decision import CloseView

    height = np.zeros((2, 8, 8), np.float32)
    height[:, 2:6, 2:6] = 0.03  # 16 object cells per world
    seen_a = np.zeros((2, 8, 8), bool)
    seen_a[:, 0:4, :] = True  # rows 2-3 of the object: 8 of 16 cells
    seen_b = np.zeros((2, 8, 8), bool)
    seen_b[0] = True  # world 0 sees everything, world 1 nothing
    a = jnp.array([[3, 2, 2], [3, 2, 2]], jnp.int32)
    b = jnp.array([[3, 2 + SAME_GRASP_CELLS, 2], [4, 2, 2]], jnp.int32)  # same grasp / another rotation
    view = lambda seen, act: CloseView(image=None, color=None, height=None, seen=jnp.asarray(seen), action=act)  # noqa: E731
    out = view_footprint(jnp.asarray(height), view(seen_a, a), view(seen_b, b), 0.01)
    np.testing.assert_allclose(out["seen_view"], [0.5, 0.5])
    np.testing.assert_allclose(out["seen_random"], [1.0, 0.0])
    assert out["same_grasp"].tolist() == [True, False]
    far = view_footprint(jnp.asarray(height), view(seen_a, a), view(seen_b, b.at[0, 1].add(1)), 0.01)
    assert not bool(far["same_grasp"][0])
    rows = {k: np.asarray(v) for k, v in out.items()}
    rows.update({name: np.array([1, 0], bool) for name in
                 ("direct", "oracle", "view_gdnet", "random_gdnet", "grasp_gdnet", "relook_direct")})
    rows.update(live=np.array([1, 1], bool), p_direct=np.array([0.9, 0.1]), q_max=np.array([0.9, 0.1]),
                p_view=np.array([0.5, 0.5]), direct_success_gate=np.array([1, 0], bool),
                direct_q_gate=np.array([1, 0], bool))
    entry = summarize(rows, has_ggcnn=False)["all"]
    assert entry["seen_view"] == 0.5 and entry["seen_random"] == 0.5 and entry["same_grasp"] == 0.5


def test_sign_test_on_hand_counted_splits():
    """viewpoint_rows.sign_test_p: the exact two-sided McNemar test on discordant pairs."""
    from viewpoint_rows import sign_test_p

    assert sign_test_p(0, 0) == 1.0  # no discordant pair: no evidence
    assert sign_test_p(5, 0) == pytest.approx(2 / 32)  # 5 of 5 one way: 2 * 0.5^5
    assert sign_test_p(1, 1) == 1.0  # an even split (2 * 3/4, capped)
    assert sign_test_p(10, 2) == pytest.approx(2 * (1 + 12 + 66) / 4096)  # P(X <= 2), X ~ Bin(12, 1/2), twice
    assert sign_test_p(2, 10) == sign_test_p(10, 2)
