"""bench/planner_comparison.py on a hand-made training folder: the 6-10 differences between VAGS and
its ablation under each direct planner, the verdict, the paired states, and the refusal of a
folder without its success table."""
import json
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "bench"))
import planner_comparison  # noqa: E402


def _report(g6_successes, moves=0.0):
    # Groups 1 and 6: group 6's successes of 100 attempts are the 6-10 pooled success.
    groups = [{"n_objects": 1, "attempts": 10, "successes": 9, "clearing_rate": 0.9, "rounds": 10, "viewpoint_rate": 0.0},
              {"n_objects": 6, "attempts": 100, "successes": g6_successes, "clearing_rate": 0.5, "rounds": 10,
               "viewpoint_rate": moves}]
    return {"overall": {"grasp_success_rate": 0.9, "clearing_rate": 0.6, "motion_number": 1.1 + moves,
                        "viewpoint_rate": moves, "picks_per_hour": 600.0, "success_direct": 0.9,
                        "success_after_move": 0.95 if moves else None},
            "groups_metrics": groups}


def _folder(root, six_to_ten):
    """six_to_ten: 6-10 successes of (ablation q, VAGS q, ablation success, VAGS success)."""
    for planner, (abl, vags) in (("q", six_to_ten[:2]), ("success", six_to_ten[2:])):
        d = os.path.join(root, planner)
        os.makedirs(os.path.join(d, "seed11"))
        with open(os.path.join(d, "config.json"), "w") as f:
            json.dump({"seed": 7}, f)
        with open(os.path.join(d, "gate.json"), "w") as f:
            json.dump({"live_states": 4, "gdnet": "stage2 step 80", "close_gdnet": "stage3 step 80", "rate": 0.17,
                       "states": [2, 2], "direct": [0.5, 1.0], "moved": [1.0, 1.0], "move_value": [0.4, -0.1]}, f)
        for name, g6 in (("eval_vags-no-viewpoint.json", abl), ("eval_vags.json", vags)):
            with open(os.path.join(d, "seed11", name), "w") as f:
                json.dump(_report(g6, 0.3 if name == "eval_vags.json" and planner == "q" else 0.0), f)
    # Four states: GDNet's argmax succeeds on 1, the success net's on 3, after a move on 4.
    # Attempts 0, 0, 1, 1: the move gains 0 and 0 at attempt 0, 0 and +1 at attempt 1.
    np.savez(os.path.join(root, "success", "gate_states.npz"), gdnet_success=np.array([1, 0, 0, 0]),
             direct_success=np.array([1, 1, 1, 0]), moved_success=np.array([1, 1, 1, 1]),
             objects=np.array([1, 6, 7, 8]), p_direct=np.array([0.9, 0.5, 0.6, 0.2]), attempt=np.array([0, 0, 1, 1]))


def test_the_differences_the_verdict_and_the_paired_states(tmp_path, capsys):
    _folder(str(tmp_path / "t"), (80, 90, 88, 89))
    assert planner_comparison.main([str(tmp_path / "t")]) == 0
    out = capsys.readouterr().out
    # VAGS q over ablation q +10, over ablation success +2; VAGS success over its ablation +1;
    # the ablations' difference +8.
    assert "| 7 | 11 | +10.0 | +2.0 | +1.0 | +8.0 |" in out
    assert "one planner on both sides: no" in out
    # 6-10 states (3): GDNet 0 %, the success net 66.7 %, after a move 100 %.
    assert "| 7 | 6-10 objects | 3 | 0.0 | 66.7 | 100.0 |" in out
    assert "moves in bins [0] of 2" in out
    assert "| 7 | 0 | 2 | +0.0 +- 0.0 |" in out and "| 7 | 1 | 2 | +50.0 +- 50.0 |" in out


def test_a_margin_of_five_with_one_planner_is_a_yes(tmp_path, capsys):
    _folder(str(tmp_path / "t"), (80, 90, 80, 85))
    assert planner_comparison.main([str(tmp_path / "t")]) == 0
    assert "one planner on both sides: yes" in capsys.readouterr().out


def test_a_folder_without_its_success_table_is_refused(tmp_path, capsys):
    _folder(str(tmp_path / "t"), (80, 90, 88, 89))
    os.remove(str(tmp_path / "t" / "success" / "gate.json"))
    with pytest.raises(SystemExit) as e:
        planner_comparison.main([str(tmp_path / "t")])
    assert e.value.code == 2 and "has no success/gate.json" in capsys.readouterr().err
