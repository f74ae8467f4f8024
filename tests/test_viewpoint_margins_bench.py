"""bench/viewpoint_margins.py and bench/viewpoint_goals.py's report reading, on hand-made reports."""
import gzip
import json
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "bench"))
import viewpoint_margins  # noqa: E402


def _report(success, g6_10):
    # Groups 1 and 6 only: group 6's successes / attempts give the 6-10 pooled success.
    groups = [{"n_objects": 1, "attempts": 10, "successes": 10, "clearing_rate": 1.0, "rounds": 10},
              {"n_objects": 6, "attempts": 100, "successes": g6_10, "clearing_rate": 0.5, "rounds": 10}]
    return {"overall": {"grasp_success_rate": success, "motion_number": 1.2}, "groups_metrics": groups}


def _write(path, report, gz):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with (gzip.open(path + ".gz", "wt") if gz else open(path, "w")) as f:
        json.dump(report, f)


def test_margins_per_seed_and_their_correlation_with_the_ablation(tmp_path, capsys):
    # Three seeds: ablation 0.80 / 0.85 / 0.90 with 6-10 successes 70 / 80 / 90 of 100; VAGS's
    # 6-10 successes 80 / 85 / 91: margins +10, +5, +1 points, falling as the ablation gets
    # stronger.  Deviations from the means (85; 16/3): -5, 0, 5 and 14/3, -1/3, -13/3, so the
    # covariance sum is -45, the sums of squares 50 and 122/3: slope -45/50 = -0.90,
    # correlation -45 / sqrt(50 * 122/3) = -0.998 (printed -1.00).
    for seed, (a, g_nv, g_va) in zip((11, 12, 13), ((0.80, 70, 80), (0.85, 80, 85), (0.90, 90, 91))):
        _write(str(tmp_path / "run" / f"seed{seed}" / "eval_vags-no-viewpoint.json"), _report(a, g_nv), gz=True)
        _write(str(tmp_path / "run" / f"seed{seed}" / "eval_vags.json"), _report(a + 0.03, g_va), gz=seed == 11)
    _write(str(tmp_path / "lonely" / "seed11" / "eval_vags.json"), _report(0.9, 90), gz=False)  # no ablation: skipped
    assert viewpoint_margins.main([str(tmp_path / "run"), str(tmp_path / "lonely")]) == 0
    out = capsys.readouterr().out
    assert f"| {tmp_path / 'run'} | 3 | 85.0 | 88.0 | 1.200 | +10.0, +5.0, +1.0 |" in out
    assert "lonely" not in out
    assert ("3 (folder, seed) pairs: correlation of the 6-10 margin with the ablation's success -1.00; "
            "slope -0.90") in out


def _goal_report(success, g1_viewpoint, g6_successes, g6_clearing, motion):
    """A report of groups 1 and 6 (100 attempts, 10 rounds each) with the figures the goals read."""
    groups = [{"n_objects": 1, "attempts": 100, "successes": 90, "clearing_rate": 1.0, "rounds": 10,
               "viewpoint_rate": g1_viewpoint},
              {"n_objects": 6, "attempts": 100, "successes": g6_successes, "clearing_rate": g6_clearing, "rounds": 10}]
    return {"overall": {"grasp_success_rate": success, "clearing_rate": 0.8, "motion_number": motion,
                        "viewpoint_rate": 0.2, "picks_per_hour": 600.0}, "groups_metrics": groups}


def test_goals_verdicts_per_seed_at_their_bounds(tmp_path, capsys):
    import viewpoint_goals

    # Seed 11 sits on every bound: success 85 %, +5 points on 6-10 (85 against 80 of 100), 6-10
    # clearing equal, 10 % moves at one object (all met), motion number 1.35 (missed: below).
    # Seed 12 misses the others by a little: 84.9 %, +4 points, clearing -10 points, 11 % moves.
    run = tmp_path / "run"
    for seed, vags, abl in ((11, _goal_report(0.85, 0.10, 85, 0.5, 1.35), _goal_report(0.80, 0.0, 80, 0.5, 1.1)),
                            (12, _goal_report(0.849, 0.11, 84, 0.4, 1.30), _goal_report(0.80, 0.0, 80, 0.5, 1.1))):
        _write(str(run / f"seed{seed}" / "eval_vags.json"), vags, gz=False)
        _write(str(run / f"seed{seed}" / "eval_vags-no-viewpoint.json"), abl, gz=True)
    assert viewpoint_goals.main([str(run), "--goals"]) == 0
    out = capsys.readouterr().out
    assert "| success at least 85 % | 85.0 | 84.9 (missed) | no |" in out
    assert "| 6-10 success at least 5 points above the ablation | +5.0 | +4.0 (missed) | no |" in out
    assert "| 6-10 clearing no worse than the ablation's | +0.0 | -10.0 (missed) | no |" in out
    assert "| motion number below 1.35 | 1.35 (missed) | 1.30 | no |" in out
    assert "| at one object, moves on at most 10 % of attempts | 10.0 | 11.0 (missed) | no |" in out
    assert out.rstrip().endswith("at one object, moves on at most 10 % of attempts")
    assert viewpoint_goals.main([str(run), "--goals", "--policies", "vags"]) == 2
    # One check per goal and seed: seed 11 meets four of five, seed 12 only the motion number.
    assert viewpoint_goals.checks_met(str(run), "vags", "vags-no-viewpoint", (11, 12)) == (5, 10)
    assert viewpoint_goals.checks_met(str(run), "vags", "vags-no-viewpoint", (11,)) == (4, 5)
    assert viewpoint_goals.checks_met(str(run), "vags", "vags-no-viewpoint", (11, 13)) is None
    good = tmp_path / "good"
    _write(str(good / "seed11" / "eval_vags.json"), _goal_report(0.9, 0.05, 90, 0.6, 1.2), gz=False)
    _write(str(good / "seed11" / "eval_vags-no-viewpoint.json"), _goal_report(0.8, 0.0, 80, 0.5, 1.1), gz=False)
    assert viewpoint_goals.main([str(good), "--goals"]) == 0
    assert capsys.readouterr().out.rstrip().endswith("all these goals met on every seed")


def test_goals_against_an_ablation_that_played_another_gdnet_are_not_measured(tmp_path, capsys):
    import viewpoint_goals

    # Seed 11: both reports played the same GDNet; seed 12: the ablation another one (as when it
    # is evaluated on a copy of the run whose gate table picked the other stage's GDNet).
    run = tmp_path / "run"
    for seed, abl_gdnet in ((11, "stage2 step 80"), (12, "stage3 step 80")):
        vags = {**_goal_report(0.9, 0.05, 90, 0.6, 1.2), "gdnet": "stage2 step 80"}
        abl = {**_goal_report(0.8, 0.0, 80, 0.7, 1.1), "gdnet": abl_gdnet}
        _write(str(run / f"seed{seed}" / "eval_vags.json"), vags, gz=False)
        _write(str(run / f"seed{seed}" / "eval_vags-no-viewpoint.json"), abl, gz=False)
    assert viewpoint_goals.main([str(run), "--goals"]) == 0
    out = capsys.readouterr().out
    assert "| 12 (other GDNet) | +10.0 |" in out and "| 11 | +10.0 |" in out
    assert "| 6-10 success at least 5 points above the ablation | +10.0 | +10.0 (other GDNet) | not measured |" in out
    # Clearing is missed on seed 11 (its own ablation), so that goal is missed, not unmeasured.
    assert "| 6-10 clearing no worse than the ablation's | -10.0 (missed) | -10.0 (other GDNet) | no |" in out
    assert "| motion number below 1.35 | 1.20 | 1.20 | yes |" in out
    assert ("seed 12: vags played GDNet 'stage2 step 80', vags-no-viewpoint 'stage3 step 80': not its own "
            "ablation") in out
    assert "not measured on every seed: 6-10 success at least 5 points above the ablation" in out
    assert out.rstrip().endswith("missed: 6-10 clearing no worse than the ablation's")


def _round_report(attempts, successes, scenes="s1"):
    """A report of one 6-object group whose rounds are given (for the paired table)."""
    rep = _goal_report(0.9, 0.05, sum(successes), 0.5, 1.2)
    rep["scenes"] = scenes
    rep["outcomes"] = {"6": {"attempts": attempts, "successes": successes, "n_objects": [6] * len(attempts)}}
    return rep


def test_gains_paired_round_by_round_with_their_standard_errors(tmp_path, capsys):
    import viewpoint_goals

    # Four rounds of 6 objects.  VAGS: attempts 6, 6, 8, 8 and successes 6, 6, 6, 5 (23 of 28;
    # cleared 1, 1, 1, 0); the ablation: 6, 7, 8, 9 and 6, 5, 6, 6 (23 of 30; cleared 1, 0, 1, 1).
    # Clearing: paired differences 0, +1, 0, -1: mean 0, variance 2/3, standard error
    # sqrt(2/3) / 2 = 0.408.  Success: 23/28 - 23/30 = 0.0548; each round's deviation from its
    # policy's pooled ratio over the mean attempts (7 and 7.5): VAGS +0.1531, +0.1531, -0.0816,
    # -0.2245; the ablation +0.1867, -0.0489, -0.0178, -0.1200; differences -0.0336, +0.2020,
    # -0.0639, -0.1045 (mean 0), sum of squares 0.05691, variance 0.01897, standard error
    # 0.1377 / 2 = 0.0689.
    run = tmp_path / "run"
    _write(str(run / "seed11" / "eval_vags.json"), _round_report([6, 6, 8, 8], [6, 6, 6, 5]), gz=False)
    _write(str(run / "seed11" / "eval_vags-no-viewpoint.json"), _round_report([6, 7, 8, 9], [6, 5, 6, 6]), gz=True)
    # Seed 12: the ablation played other scenes, so its rounds are not paired.
    _write(str(run / "seed12" / "eval_vags.json"), _round_report([6, 6], [6, 6]), gz=False)
    _write(str(run / "seed12" / "eval_vags-no-viewpoint.json"), _round_report([6, 6], [6, 6], scenes="s2"), gz=False)
    assert viewpoint_goals.main([str(run)]) == 0
    out = capsys.readouterr().out
    assert "| 11 | 4 | +5.5 ± 6.9 | +0.0 ± 40.8 |" in out
    assert "| 12 | not paired (no per-round outcomes or other scenes) | | |" in out
    assert "| all |" not in out  # a seed that cannot be paired: no pooled row
    # Seeds 11 and 13 alike, both paired: the pooled row has their 8 rounds.  Clearing: differences
    # 0, +1, 0, -1 twice, mean 0, variance 4/7, standard error sqrt(4/7) / sqrt(8) = 0.267.  Success:
    # the same deviations twice, sum of squares 0.11382, variance 0.01626, standard error 0.0451.
    two = tmp_path / "two"
    for seed in (11, 13):
        _write(str(two / f"seed{seed}" / "eval_vags.json"), _round_report([6, 6, 8, 8], [6, 6, 6, 5]), gz=False)
        _write(str(two / f"seed{seed}" / "eval_vags-no-viewpoint.json"), _round_report([6, 7, 8, 9], [6, 5, 6, 6]),
               gz=False)
    assert viewpoint_goals.main([str(two)]) == 0
    assert "| all | 8 | +5.5 ± 4.5 | +0.0 ± 26.7 |" in capsys.readouterr().out
    # Reports without per-round outcomes (as the other tests' hand-made ones) print no such table.
    bare = tmp_path / "bare"
    _write(str(bare / "seed11" / "eval_vags.json"), _goal_report(0.9, 0.05, 90, 0.6, 1.2), gz=False)
    _write(str(bare / "seed11" / "eval_vags-no-viewpoint.json"), _goal_report(0.8, 0.0, 80, 0.5, 1.1), gz=False)
    assert viewpoint_goals.main([str(bare)]) == 0
    assert "paired round by round" not in capsys.readouterr().out


def test_paired_across_trainings_and_over_all_of_them(tmp_path, capsys):
    import viewpoint_goals

    # Two trainings, each seeds 11 and 13 as in the test above (8 paired rounds: success +5.5 ± 4.5,
    # clearing +0.0 ± 26.7; one group, so "all rounds" is the same).  Pooled: 16 rounds, the same
    # deviations four times: success sum of squares 0.22764, variance 0.015176, standard error
    # 0.1232 / 4 = 0.0308; clearing variance 8/15, standard error 0.7303 / 4 = 0.1826.  A third
    # folder lacks its ablation: named, and left out of "all".
    folders = [tmp_path / "t1", tmp_path / "t2", tmp_path / "t3"]
    for folder in folders[:2]:
        for seed in (11, 13):
            _write(str(folder / f"seed{seed}" / "eval_vags.json"), _round_report([6, 6, 8, 8], [6, 6, 6, 5]), gz=False)
            _write(str(folder / f"seed{seed}" / "eval_vags-no-viewpoint.json"),
                   _round_report([6, 7, 8, 9], [6, 5, 6, 6]), gz=True)
    _write(str(folders[2] / "seed11" / "eval_vags.json"), _round_report([6, 6], [6, 6]), gz=False)
    assert viewpoint_goals.main([str(folders[0]), "--across"] + [str(f) for f in folders[1:]]) == 0
    out = capsys.readouterr().out
    assert f"| {folders[0]} | 8 | +5.5 ± 4.5 | +0.0 ± 26.7 | +0.0 ± 26.7 |" in out
    assert f"| {folders[1]} | 8 | +5.5 ± 4.5 | +0.0 ± 26.7 | +0.0 ± 26.7 |" in out
    assert f"| {folders[2]} | not paired" in out
    assert "| all | 16 | +5.5 ± 3.1 | +0.0 ± 18.3 | +0.0 ± 18.3 |" in out
    assert viewpoint_goals.main([str(folders[0]), "--across", str(folders[1]), "--policies", "vags"]) == 2


def _loss_report(rounds, extra=1):
    """A report of one 6-object group whose rounds are (attempts, successes, remaining, viewpoints,
    lost_after_move, lost_at_start) tuples, with an attempt budget of 2k + extra."""
    cols = list(zip(*rounds))
    rep = _goal_report(0.9, 0.05, sum(cols[1]), 0.5, 1.2)
    rep["max_attempts"] = f"2 * objects + {extra}"
    rep["outcomes"] = {"6": {"n_objects": [6] * len(rounds), **{k: list(v) for k, v in zip(
        ("attempts", "successes", "remaining", "viewpoints", "lost_after_move", "lost_at_start"), cols)}}}
    return rep


def test_where_the_objects_were_lost_and_which_rounds_ran_out_of_attempts(tmp_path, capsys):
    import viewpoint_goals

    # VAGS: a clean round; a round that lost 2 of 6 (one gone before its first attempt, one knocked
    # off after a move); a round that lost one by a direct grasp and ended with one left after its
    # 2 * 6 + 1 = 13 attempts.  26 attempts, 5 after a move: 1 of 5 (20.0 %) and 1 of 21 (4.8 %).
    # The ablation: a clean round, a round that lost one by a direct grasp, and a round cleared at
    # its 13th attempt (not out of attempts: nothing was left).
    run = tmp_path / "run"
    vags = [(6, 6, 0, 2, 0, 0), (7, 4, 0, 3, 1, 1), (13, 4, 1, 0, 0, 0)]
    abl = [(6, 6, 0, 0, 0, 0), (8, 5, 0, 0, 0, 0), (13, 6, 0, 0, 0, 0)]
    _write(str(run / "seed11" / "eval_vags.json"), _loss_report(vags), gz=False)
    _write(str(run / "seed11" / "eval_vags-no-viewpoint.json"), _loss_report(abl), gz=True)
    assert viewpoint_goals.main([str(run)]) == 0
    out = capsys.readouterr().out
    assert "Where the objects of the 6-10 piles were lost (1 seed pooled)" in out
    assert "| vags | 26 | 5 | 3 | 1 | 1 (20.0 %) | 1 (4.8 %) | 2 of 3 | 1 | 1 of 3 |" in out
    assert "| vags-no-viewpoint | 27 | 0 | 1 | 0 | - | 1 (3.7 %) | 1 of 3 | 0 | 2 of 3 |" in out
    # A budget of 2k + 2: the third VAGS round (13 attempts) did not run out; reports from before
    # the per-round losses were recorded print no row.
    assert viewpoint_goals.losses(_loss_report(vags, extra=2), 6, 10)["out"] == 0
    old = _loss_report(vags)
    del old["outcomes"]["6"]["lost_at_start"]
    assert viewpoint_goals.losses(old, 6, 10) is None
    _write(str(run / "seed11" / "eval_vags.json"), old, gz=False)
    assert viewpoint_goals.main([str(run)]) == 0
    out = capsys.readouterr().out
    assert "| vags-no-viewpoint | 27 |" in out and "| vags | 26 |" not in out


def test_gate_lost_table_over_the_looks_gate_tables(tmp_path):
    """``viewpoint_goals.gate_lost_table``: one row per gate table whose direct grasp GDNet
    planned (tables without ``lost``, or planned by the success net, are left out), per 100
    states, then the moving bins' range and mean."""
    import viewpoint_goals

    def gate(path, score, moved_bins_diff, lost=True):
        os.makedirs(path)
        g = {"direct_score": score}
        if lost:
            g["lost"] = {"all": {"states": 100, "direct": 0.03, "moved": 0.02, "difference": -0.01, "se": 0.005},
                         "moved_bins": {"states": 20, "direct": 0.1, "moved": 0.1 + moved_bins_diff,
                                        "difference": moved_bins_diff, "se": 0.01}}
        with open(os.path.join(path, "gate.json"), "w") as f:
            json.dump(g, f)

    gate(str(tmp_path / "first_look" / "a"), "q", -0.02)
    gate(str(tmp_path / "first_look" / "b"), "success", -0.5)  # left out: the success net planned it
    gate(str(tmp_path / "second_look" / "c"), "q_mean", 0.01)
    gate(str(tmp_path / "second_look" / "d"), "q", -0.5, lost=False)  # left out: no `lost`
    lines = viewpoint_goals.gate_lost_table(str(tmp_path), ("first", "second"))
    assert lines[2:4] == ["| first/a | q | 100 | 3.0 | 2.0 | -1.0 ± 0.5 | 20 | 10.0 | 8.0 | -2.0 ± 1.0 |",
                          "| second/c | q_mean | 100 | 3.0 | 2.0 | -1.0 ± 0.5 | 20 | 10.0 | 11.0 | +1.0 ± 1.0 |"]
    assert lines[-1] == "2 tables; moving bins, moved - direct: -2.0 to +1.0, mean -0.50 points"
