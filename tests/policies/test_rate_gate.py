"""The "rate" gate (vags_jax/policies/rate_gate.py): Dinkelbach's choice, the binned table, the
lookup inside the decision, RUN/gate.json; expectations worked out by hand."""
import dataclasses
import json
import os

import jax.numpy as jnp
import numpy as np
import pytest

from vags_jax.policies import rate_gate
from vags_jax.policies.decision import decide, gate_score, gate_threshold
from vags_jax import config as C


def test_best_rate_moves_exactly_the_bins_that_raise_picks_per_second():
    # Two bins of 10 states.  Direct: success 0.9 and 0.5 in 5 s each -> 7 picks / 100 s = 0.07.
    # A move adds 1 s and lifts bin 1 to 0.8: moving bin 1 gives (9 + 8) / (50 + 60) = 0.1545...;
    # moving bin 0 too (0.92 there) gives (9.2 + 8) / 120 = 0.1433, lower: only bin 1 moves.
    rate, move = rate_gate.best_rate([10, 10], [0.9, 0.5], [5, 5], [0.92, 0.8], [6, 6])
    assert move.tolist() == [False, True]
    assert rate == pytest.approx(17 / 110)
    # A move that costs no time and adds success is always taken; one that adds nothing, never.
    rate, move = rate_gate.best_rate([1, 1], [0.5, 0.5], [4, 4], [0.6, 0.5], [4, 6])
    assert move.tolist() == [True, False] and rate == pytest.approx(1.1 / 8)


def test_fit_bins_by_quantiles_and_values_moves_at_the_best_rate():
    # p_direct 0.1..0.8 in 2 bins (edge: the median 0.45).  Low bin: direct 0/4, moved 4/4,
    # 2 s more; high bin: direct 4/4, moved 2/4, 2 s more.  Direct alone: 4 picks / 40 s; moving
    # the low bin: 8 / 48 = 1/6 per s, the best.  Values: low 1 - 2/6 = 2/3; high -0.5 - 1/3.
    p = np.arange(1, 9) / 10
    s_d = np.array([0, 0, 0, 0, 1, 1, 1, 1])
    s_m = np.array([1, 1, 1, 1, 1, 0, 1, 0])
    t_d = np.full(8, 5.0)
    t_m = np.full(8, 7.0)
    t = rate_gate.fit(p, s_d, t_d, s_m, t_m, 2)
    assert t.edges == pytest.approx((0.45,)) and t.states == (4, 4)
    assert t.direct == (0.0, 1.0) and t.moved == (1.0, 0.5) and t.extra_seconds == (2.0, 2.0)
    assert t.rate == pytest.approx(1 / 6)
    assert t.move_value == pytest.approx((2 / 3, -0.5 - 1 / 3))
    # Standard errors over each bin's states: the low bin's four values are all 2/3 (0); the high
    # bin's are -1/3, -4/3, -1/3, -4/3 (mean -5/6, squared deviations 1 over 3 degrees of
    # freedom): sqrt(1 / 3 / 4).
    assert t.move_value_se == pytest.approx((0.0, np.sqrt(1 / 12)))
    np.testing.assert_allclose(t.array(), [[0.45, np.inf], [2 / 3, -0.5 - 1 / 3]], rtol=1e-6)
    # Objects knocked off, per bin and paired: direct loses one in each bin (1/4 and 1/4), the
    # move three in the low bin and none in the high one (3/4, 0).  Over all 8 states the paired
    # differences are [1, 0, 0, 1, 0, 0, 0, -1]: mean 1/8, squared deviations 2.875 over 7 degrees
    # of freedom; over the moving (low) bin [1, 0, 0, 1]: mean 1/2, standard deviation sqrt(1/3).
    l_d = np.array([0, 1, 0, 0, 0, 0, 0, 1])
    l_m = np.array([1, 1, 0, 1, 0, 0, 0, 0])
    t = rate_gate.fit(p, s_d, t_d, s_m, t_m, 2, lost_direct=l_d, lost_moved=l_m)
    assert t.lost_direct == (0.25, 0.25) and t.lost_moved == (0.75, 0.0)
    assert t.move_value == pytest.approx((2 / 3, -0.5 - 1 / 3))  # the decision ignores them
    pl = rate_gate.paired_lost(t, p, l_d, l_m)
    assert pl["all"]["states"] == 8 and pl["all"]["direct"] == 0.25 and pl["all"]["moved"] == 0.375
    assert pl["all"]["difference"] == pytest.approx(1 / 8) and pl["all"]["se"] == pytest.approx(np.sqrt(2.875 / 7 / 8))
    assert pl["moved_bins"]["states"] == 4 and pl["moved_bins"]["difference"] == pytest.approx(0.5)
    assert pl["moved_bins"]["se"] == pytest.approx(np.sqrt(1 / 3) / 2)
    assert "| 25.0 | 75.0 |" in rate_gate.describe(t) and not t.count_lost
    # Counted as picks lost, net picks per attempt are low bin -0.25 direct, 0.25 moved; high bin
    # 0.75 and 0.5.  Direct alone: 2 / 40 s; moving the low bin: 4 / 48 s = 1/12, the best (both:
    # 3 / 56).  Values: low 0.5 - 2/12 = 1/3; high -0.25 - 1/6 = -5/12.
    c = rate_gate.fit(p, s_d, t_d, s_m, t_m, 2, lost_direct=l_d, lost_moved=l_m, count_lost=True)
    assert c.count_lost and c.rate == pytest.approx(1 / 12) and c.move_value == pytest.approx((1 / 3, -5 / 12))
    assert c.direct == t.direct and c.moved == t.moved  # the table still shows plain success
    assert rate_gate.describe(c).startswith("net picks (picks minus objects knocked off) per second")
    with pytest.raises(ValueError, match="count_lost needs"):
        rate_gate.fit(p, s_d, t_d, s_m, t_m, 2, count_lost=True)
    assert "moved_bins (4 states): direct 0.250, after a move 0.750, paired difference +0.500 +- 0.289" in \
        rate_gate.describe_lost(pl)
    # Ties: 8 equal estimates make one bin, whatever was asked.
    assert rate_gate.fit(np.full(8, 0.5), s_d, t_d, s_m, t_m, 4).states == (8,)
    with pytest.raises(ValueError, match="one state per bin: 3 states for 4 bins"):
        rate_gate.fit(p[:3], s_d[:3], t_d[:3], s_m[:3], t_m[:3], 4)


def test_the_rate_gate_moves_where_the_table_says_a_move_pays():
    table = jnp.array([[0.3, 0.7, jnp.inf], [0.2, -0.1, -0.4]], jnp.float32)
    p_direct = jnp.array([0.1, 0.3, 0.5, 0.95])  # bins 0, 1 (an edge belongs to the upper bin), 1, 2
    np.testing.assert_allclose(np.asarray(rate_gate.move_value(table, p_direct)), [0.2, -0.1, -0.1, -0.4], rtol=1e-6)
    np.testing.assert_allclose(np.asarray(gate_score("rate", None, p_direct, None, None, "mean", table)),
                               [-0.2, 0.1, 0.1, 0.4], rtol=1e-6)
    with pytest.raises(ValueError, match="gate_measure"):
        gate_score("rate", None, p_direct, None)
    assert float(gate_threshold(C.replace(C.Config(), **{"vags.gate": "rate"}).vags, 1.7)) == 0.0
    # decide: world 0's success estimate (0.1) falls in the bin where a move pays; world 1's (0.8) does not.
    qg = np.zeros((2, 1, 2, 2), np.float32)
    qg[:, 0, 1, 1] = 1.0
    qs = np.zeros((2, 1, 2, 2), np.float32)
    qs[:, 0, 1, 1] = [0.1, 0.8]
    d = decide(jnp.asarray(qg), jnp.asarray(qg[:, 0]), 0.0, jnp.asarray(qs), "rate", gate_table=table)
    assert np.asarray(d.direct).tolist() == [False, True]


def test_gate_json_round_trip_and_stale_tables(tmp_path):
    t = rate_gate.GateTable(edges=(0.5,), states=(3, 5), direct=(0.2, 0.9), moved=(0.7, 0.8),
                            extra_seconds=(1.0, 1.2), rate=0.15, move_value=(0.35, -0.28))
    path = rate_gate.save(str(tmp_path), t, {"networks": "stage3 step 80", "worlds": 4})
    assert json.load(open(path))["worlds"] == 4
    np.testing.assert_allclose(rate_gate.load(str(tmp_path)), [[0.5, np.inf], [0.35, -0.28]], rtol=1e-6)
    assert rate_gate.load(str(tmp_path), "stage3 step 80") is not None
    assert rate_gate.load(str(tmp_path), "stage3 step 96") is None  # measured on other networks
    assert rate_gate.load(str(tmp_path / "nothing")) is None
    # A table from before the GDNet was recorded was measured on its networks' own GDNet.
    assert rate_gate.load(str(tmp_path), "stage3 step 80", "stage3 step 80") is not None
    assert rate_gate.load(str(tmp_path), "stage3 step 80", "stage2 step 40") is None
    rate_gate.save(str(tmp_path), t, {"networks": "stage3 step 80", "gdnet": "stage2 step 40"})
    assert rate_gate.load(str(tmp_path), "stage3 step 80", "stage2 step 40") is not None
    assert rate_gate.load(str(tmp_path), "stage3 step 80", "stage3 step 80") is None  # another GDNet's table
    assert rate_gate.read(str(tmp_path))["gdnet"] == "stage2 step 40"
    # A table from before the close-view GDNet was recorded grasped after a move with its "gdnet".
    assert rate_gate.load(str(tmp_path), "stage3 step 80", "stage2 step 40", "stage2 step 40") is not None
    assert rate_gate.load(str(tmp_path), "stage3 step 80", "stage2 step 40", "stage3 step 80") is None
    rate_gate.save(str(tmp_path), t, {"networks": "stage3 step 80", "gdnet": "stage2 step 40",
                                      "close_gdnet": "stage3 step 80"})
    assert rate_gate.load(str(tmp_path), "stage3 step 80", "stage2 step 40", "stage3 step 80") is not None
    assert rate_gate.load(str(tmp_path), "stage3 step 80", "stage2 step 40", "stage2 step 40") is None
    # A table written before the objects lost were recorded still loads.
    json.dump({k: v for k, v in json.load(open(path)).items() if not k.startswith("lost_")}, open(path, "w"))
    np.testing.assert_allclose(rate_gate.load(str(tmp_path)), [[0.5, np.inf], [0.35, -0.28]], rtol=1e-6)


def _three_bins(move_value=(0.3, 0.01, 0.2)):
    # Three bins of 10 states: direct 0.4 / 0.7 / 0.5, after a move 0.9 / 0.8 / 0.8 (success
    # gains 0.5, 0.1, 0.3); every bin moves at first.
    return rate_gate.GateTable(edges=(0.3, 0.6), states=(10, 10, 10), direct=(0.4, 0.7, 0.5),
                               moved=(0.9, 0.8, 0.8), extra_seconds=(1.0, 1.0, 1.0), rate=0.1,
                               move_value=move_value)


def test_the_motion_cap_drops_the_moves_that_add_least_success(tmp_path):
    t = _three_bins()
    # All three move: 60 motions over 9 + 8 + 8 = 25 grasped objects -> 2.4.  None: 30 / 16.
    assert rate_gate.motion_number(t, [True, True, True]) == pytest.approx(60 / 25)
    assert rate_gate.motion_number(t, [False, False, False]) == pytest.approx(30 / 16)
    assert rate_gate.capped(t, 0.0) is t  # no cap
    # Cap 2.3: bin 1 (the smallest gain, 0.1) goes: 50 / 24 = 2.083 <= 2.3.  A dropped bin's
    # value is negated: the decision grasps directly only where it is below 0.
    assert rate_gate.capped(t, 2.3).move_value == pytest.approx((0.3, -0.01, 0.2))
    # Cap 2.05: bin 2 (gain 0.3) goes next: 40 / 21 = 1.905.
    assert rate_gate.capped(t, 2.05).move_value == pytest.approx((0.3, -0.01, -0.2))
    # The order is by success gain, not move value: here bin 2 has the smallest move value, yet
    # bin 1 goes.  A bin that never moved keeps its own (negative) value.
    c = rate_gate.capped(_three_bins((0.3, 0.25, 0.05)), 2.3)
    assert c.move_value == pytest.approx((0.3, -0.25, 0.05))
    assert rate_gate.capped(_three_bins((0.3, -0.4, 0.2)), 2.3).move_value == pytest.approx((0.3, -0.4, 0.2))
    assert rate_gate.capped(t, 1.0).move_value == pytest.approx((-0.3, -0.01, -0.2))  # under any choice: none move
    np.testing.assert_allclose(c.array()[1], [0.3, -0.25, 0.05], rtol=1e-6)
    # The decision itself (the "rate" gate's score against its threshold) grasps directly in the
    # dropped bins and moves in the kept one; a table capped by a cap it already meets plays as
    # the uncapped one.
    from vags_jax.policies.decision import gate_score
    p = jnp.asarray([0.1, 0.5, 0.9])

    def moved(table):
        score = gate_score("rate", None, p, None, gate_table=jnp.asarray(table.array()))
        return (~(score > 0)).tolist()

    assert moved(rate_gate.capped(t, 2.05)) == [True, False, False]
    assert moved(rate_gate.capped(_three_bins((0.3, -0.4, 0.2)), 2.3)) == [True, False, True]
    # A bin whose move is worth exactly nothing (0: e.g. no grasp succeeds in either branch of a
    # barely trained run) grasps directly, as moves_summary counts it.
    assert moved(_three_bins((0.3, 0.0, -0.2))) == [True, False, False]
    assert rate_gate.moves_summary(_three_bins((0.3, 0.0, -0.2)))["moving_bins"] == [0]
    # Loaded from RUN/gate.json with the cap; the summary eval.py logs and writes.
    rate_gate.save(str(tmp_path), t, {"networks": "stage3 step 8"})
    np.testing.assert_allclose(rate_gate.load(str(tmp_path), "stage3 step 8", max_motion_number=2.3)[1],
                               [0.3, -0.01, 0.2], rtol=1e-6)
    s = rate_gate.moves_summary(rate_gate.load_table(str(tmp_path), max_motion_number=2.3), 2.3)
    assert s == {"moving_bins": [0, 2], "bins": 3, "motion_number": round(50 / 24, 4),
                 "success": round(24 / 30, 4), "max_motion_number": 2.3, "min_z": 0.0, "close_bins": []}
    assert rate_gate.motion_number_text(s["motion_number"]) == "2.083"


def test_bins_whose_choice_is_within_the_noise_are_named():
    """``close_bins``: a bin whose move value is within two standard errors of 0.  Two bins of
    four states, no extra seconds (so the rate does not enter): the low bin gains 1 on every
    state (value 1, error 0); the high bin's gains are 0, 1, -1, 0 (value 0, squared deviations 2
    over 3 degrees of freedom: error sqrt(2 / 3 / 4)), so the high bin is named, and flagged in
    the table train.py prints and in the summary eval.py writes."""
    p = np.arange(1, 9) / 10
    t = rate_gate.fit(p, [0, 0, 0, 0, 1, 0, 1, 0], np.full(8, 5.0), [1, 1, 1, 1, 1, 1, 0, 0], np.full(8, 5.0), 2)
    assert t.move_value == pytest.approx((1.0, 0.0)) and t.move_value_se == pytest.approx((0.0, np.sqrt(1 / 6)))
    assert rate_gate.close_bins(t) == [1] and rate_gate.moves_summary(t)["close_bins"] == [1]
    text = rate_gate.describe(t)
    assert "| +1.000 ± 0.000 | yes |" in text and "| +0.000 ± 0.408 | no * |" in text
    assert "* bins [1]: the move value is within two standard errors of 0" in text
    # What the table predicts: the low bin moves (4 states, all grasped after a move: 8 motions),
    # the high bin grasps directly (2 of 4): 8 + 4 motions for 6 objects.  Bin 1 does not move,
    # so there is no line for vags.gate_min_z.
    assert "predicted on these states: 2.000 motions per grasped object, 75.0 % success, moving in bins [0]" in text
    assert "gate_min_z" not in text and rate_gate.close_moving_bins(t) == []
    # Bin 1 moving by a hair (+0.1, error 0.408; its moves grasp 2 of 4): 16 motions for 6 objects, and
    # the line with gate_min_z=2 drops it.
    hair = dataclasses.replace(t, move_value=(1.0, 0.1))
    assert rate_gate.close_moving_bins(hair) == [1]
    text = rate_gate.describe(hair)
    assert "predicted on these states: 2.667 motions per grasped object, 75.0 % success, moving in bins [0, 1]" in text
    assert ("with --set vags.gate_min_z=2 (grasp directly in the moving bins marked *): 2.000 motions per grasped "
            "object, 75.0 % success, moving in bins [0]") in text
    # A gate.json from before the errors were recorded: nothing named, no errors shown.
    old = rate_gate.from_dict({k: v for k, v in json.loads(json.dumps(t.__dict__)).items() if k != "move_value_se"})
    assert old.move_value_se == () and rate_gate.close_bins(old) == [] and "±" not in rate_gate.describe(old)


def test_a_table_where_nothing_succeeds_predicts_no_motion_number():
    """A barely trained run's table (no grasp succeeded in either branch) has no motion number:
    inf for the cap (every move dropped), None in the summary eval.py writes as JSON, "-" in its
    log, where it printed 8e12 before."""
    t = rate_gate.GateTable(edges=(0.5,), states=(4, 4), direct=(0.0, 0.0), moved=(0.0, 0.0),
                            extra_seconds=(0.5, 0.2), rate=0.0, move_value=(0.1, -0.1))
    assert rate_gate.motion_number(t, [False, False]) == float("inf")
    assert rate_gate.capped(t, 1.5).move_value == pytest.approx((-0.1, -0.1))
    s = rate_gate.moves_summary(t)
    assert s["motion_number"] is None and s["success"] == 0.0 and s["moving_bins"] == [0]
    assert rate_gate.motion_number_text(s["motion_number"]) == "-"


def test_min_z_keeps_only_the_moves_the_table_shows_to_pay(tmp_path):
    """``vags.gate_min_z``: a bin of positive move value within that many standard errors of 0
    grasps directly (its value negated, as the cap drops a bin); bins clear of their noise, bins
    that never moved and a bin of one state (error 0) keep their choice; applied before the cap
    when the table loads, and recorded in the summary eval.py writes."""
    t = dataclasses.replace(_three_bins((0.3, 0.01, 0.2)), move_value_se=(0.02, 0.02, 0.15))
    assert rate_gate.significant(t, 0.0) is t
    assert rate_gate.significant(t, 1.0).move_value == pytest.approx((0.3, -0.01, 0.2))  # 0.2 > 1 x 0.15
    assert rate_gate.significant(t, 2.0).move_value == pytest.approx((0.3, -0.01, -0.2))  # 0.2 < 2 x 0.15
    # Exactly the positive bins that close_bins names at the same z.
    assert rate_gate.close_bins(t, 2.0) == [1, 2]
    neg = dataclasses.replace(t, move_value=(0.3, -0.01, 0.2), move_value_se=(0.0, 0.02, 0.15))
    assert rate_gate.significant(neg, 2.0).move_value == pytest.approx((0.3, -0.01, -0.2))
    # The decision grasps directly in the dropped bins.
    p = jnp.asarray([0.1, 0.5, 0.9])
    score = gate_score("rate", None, p, None, gate_table=jnp.asarray(rate_gate.significant(t, 1.0).array()))
    assert (~(score > 0)).tolist() == [True, False, True]
    # Loaded: the noise first, then the cap on what is left.  Without min_z, the cap 2.3 drops
    # bin 1 (the smallest gain) and keeps bins 0 and 2 (capped's test above); with min_z 2 bins
    # 1 and 2 are gone before the cap, which then has nothing left to drop.
    rate_gate.save(str(tmp_path), t, {"networks": "stage3 step 8"})
    np.testing.assert_allclose(rate_gate.load(str(tmp_path), max_motion_number=2.3)[1], [0.3, -0.01, 0.2], rtol=1e-6)
    np.testing.assert_allclose(rate_gate.load(str(tmp_path), max_motion_number=2.3, min_z=2.0)[1],
                               [0.3, -0.01, -0.2], rtol=1e-6)
    s = rate_gate.moves_summary(rate_gate.load_table(str(tmp_path), min_z=2.0), 0.0, 2.0)
    assert s["moving_bins"] == [0] and s["min_z"] == 2.0 and s["motion_number"] == round(40 / 21, 4)


def test_min_z_on_a_table_without_standard_errors_says_what_to_do(tmp_path):
    t = _three_bins()  # no move_value_se: measured before the errors were recorded
    assert rate_gate.significant(t, 0.0) is t
    with pytest.raises(rate_gate.NoStandardErrors, match="gate_measure --run RUN, or drop vags.gate_min_z"):
        rate_gate.significant(t, 2.0)
    rate_gate.save(str(tmp_path), t, {"networks": "stage3 step 8"})
    with pytest.raises(ValueError, match="no standard errors"):
        rate_gate.load(str(tmp_path), min_z=2.0)


@pytest.mark.parametrize("bad", [-0.5, 11.0, float("nan")])
def test_min_z_must_be_a_number_of_standard_errors(bad):
    with pytest.raises(ValueError, match=r"vags.gate_min_z must be (in \[0, 10\] standard errors|a finite number)"):
        C.replace(C.tiny(), **{"vags.gate_min_z": bad})


@pytest.mark.parametrize("bad", [0.5, -1.0, 11.0, float("nan")])
def test_the_motion_cap_must_be_off_or_a_motion_number(bad):
    with pytest.raises(ValueError, match="max_motion_number must be"):
        C.replace(C.tiny(), **{"vags.max_motion_number": bad})


def _success_map():
    """One world's success map (1, 4 rotations, 4, 4): zeros, with 0.8 at the grasp (rotation 1,
    row 0, col 1), 0.4 at the same grasp turned half a turn (rotation 3), and 0.9 on rotation 1's
    cell (1, 1) next to it."""
    q = np.zeros((1, 4, 4, 4), np.float32)
    q[0, 1, 0, 1], q[0, 3, 0, 1], q[0, 1, 1, 1] = 0.8, 0.4, 0.9
    return jnp.asarray(q), jnp.array([[1, 0, 1]], jnp.int32)


def test_success_estimates_of_a_grasp_worked_out_by_hand():
    from vags_jax.policies.decision import success_estimate, success_estimates
    q, grasp = _success_map()
    assert float(success_estimate(q, grasp, "grasp")[0]) == pytest.approx(0.8)
    assert float(success_estimate(q, grasp, "symmetric")[0]) == pytest.approx(0.6)  # (0.8 + 0.4) / 2
    # "window": the 3 x 3 cells around (0, 1) inside the map are 6 (row 0 is the edge): rotation 1
    # sums 0.8 + 0.9, rotation 3 sums 0.4 -> (1.7 / 6 + 0.4 / 6) / 2.
    assert float(success_estimate(q, grasp, "window")[0]) == pytest.approx(2.1 / 12, rel=1e-6)
    got = {k: float(v[0]) for k, v in success_estimates(q, 2.0 * q, grasp).items()}
    assert got["p_grasp"] == pytest.approx(0.8) and got["p_best"] == pytest.approx(0.9)
    assert got["q_direct"] == pytest.approx(1.6)  # GDNet's map (here 2 x q) at the grasp
    with pytest.raises(ValueError, match="even number of grasp rotations"):
        success_estimate(q[:, :3], grasp, "symmetric")
    # Over half a turn (grasp.half_turn) rotation 3 is another grasp: "symmetric" is the grasp's
    # own value and "window" its own rotation's 3 x 3 mean.
    assert float(success_estimate(q, grasp, "symmetric", half_turn=True)[0]) == pytest.approx(0.8)
    assert float(success_estimate(q, grasp, "window", half_turn=True)[0]) == pytest.approx(1.7 / 6, rel=1e-6)
    got = {k: float(v[0]) for k, v in success_estimates(q, 2.0 * q, grasp, half_turn=True).items()}
    assert got["p_symmetric"] == pytest.approx(0.8)


def test_the_decision_reads_the_configured_estimate():
    # The same table, two estimates of the one grasp: 0.8 ("grasp") keeps it direct, 0.6
    # ("symmetric") falls in the bin where a move pays.
    from vags_jax.policies.decision import decide
    q, grasp = _success_map()
    table = jnp.array([[0.7, jnp.inf], [0.2, -0.1]], jnp.float32)
    qg = jnp.zeros_like(q).at[0, 1, 0, 1].set(1.0)  # GDNet's argmax is the grasp
    qv = jnp.zeros((1, 4, 4), jnp.float32)
    assert bool(decide(qg, qv, 0.0, q, "rate", gate_table=table).direct[0])
    assert not bool(decide(qg, qv, 0.0, q, "rate", gate_table=table, gate_estimate="symmetric").direct[0])


def test_a_table_fit_on_another_estimate_says_how_to_evaluate_it():
    from types import SimpleNamespace
    from vags_jax.policies.catalog import vags_params
    cfg = C.replace(C.Config(), **{"vags.gate": "rate"})
    nets = SimpleNamespace(success=(), ggcnn=None, q_threshold=np.float32(0.0), gdnet=None, vanet=None,
                           calibration=None, gate_table=np.zeros((2, 1), np.float32), source="stage3 step 8",
                           gate_estimate="symmetric")
    with pytest.raises(ValueError, match="--set vags.gate_estimate=symmetric"):
        vags_params(nets, cfg)
    with pytest.raises(ValueError, match="vags.gate_estimate must be one of"):
        C.replace(C.Config(), **{"vags.gate_estimate": "mean"})


def test_eval_py_loads_the_networks_with_the_set_cap_and_gdnet_pick(tmp_path, monkeypatch):
    """``eval.py --set vags.max_motion_number=...`` (and ``vags.stage3_gdnet_pick``) must reach the
    networks eval.py loads, whose gate table the decision plays, not only its report
    (``requests.LOAD_FIELDS``); other --set fields leave the run's config as it is."""
    from types import SimpleNamespace
    from vags_jax.benchmark import requests
    seen = []
    monkeypatch.setattr(requests.checkpoint, "load_config", lambda run: C.tiny())
    monkeypatch.setattr(requests.rundir, "load_vags",
                        lambda run, cfg=None, **kw: seen.append(cfg) or SimpleNamespace(ggcnn=None))
    monkeypatch.setattr(requests.os.path, "exists", lambda path: True)
    args = SimpleNamespace(run=str(tmp_path), step=None, networks=None)
    requests._run_config(args, "vags", {"vags.max_motion_number": 1.3, "vags.stage3_gdnet_pick": "last",
                                        "vags.close_score": "success", "vags.gate_min_z": 2.0})
    assert seen[-1].vags.max_motion_number == 1.3 and seen[-1].vags.stage3_gdnet_pick == "last"
    assert seen[-1].vags.gate_min_z == 2.0
    assert seen[-1].vags.close_score == "q"  # read where the networks are used, not where they load
    requests._run_config(args, "vags", {"benchmark.rounds": 3})
    assert seen[-1] is None  # the run's own config


def _split_states(p=None):
    # 30 states in three bins of 10 by p: direct grasps succeed 5/10, 8/10 (failing at the bin's
    # 1st and 6th lowest p) and 10/10; after a move all succeed; a move adds 2 s to 10 s.
    p = np.arange(30) / 30.0 if p is None else np.asarray(p)
    direct = np.ones(30)
    direct[0:10:2] = 0.0
    direct[[10, 15]] = 0.0
    return {"p_direct": p, "direct_success": direct, "moved_success": np.ones(30),
            "direct_seconds": np.full(30, 10.0), "moved_seconds": np.full(30, 12.0),
            "direct_lost": np.zeros(30), "moved_lost": np.zeros(30), "objects": np.full(30, 5)}


def _fit(s):
    return rate_gate.fit(s["p_direct"], s["direct_success"], s["direct_seconds"], s["moved_success"],
                         s["moved_seconds"], 3, lost_direct=s["direct_lost"], lost_moved=s["moved_lost"])


def test_the_split_cap_moves_part_of_the_bin_whole_bins_would_drop(tmp_path):
    s = _split_states()
    t = _fit(s)
    assert t.states == (10, 10, 10) and rate_gate.moves_summary(t)["moving_bins"] == [0, 1]
    # Uncapped: 50 motions for 30 grasped objects.  Whole bins under a cap of 1.55 drop bin 1
    # (gain 0.2 < 0.5): 40 motions for 28 objects = 1.429, far under the cap.
    assert rate_gate.motion_number(t, [True, True, False]) == pytest.approx(50 / 30)
    whole = rate_gate.capped(t, 1.55)
    assert rate_gate.moves_summary(whole)["moving_bins"] == [0]
    # Split: moving bin 1's m lowest states gives (40 + m) motions for 28 + (its failures among
    # them) objects: m = 6 -> 46 / 30 = 1.533 (m = 7: 47 / 30 = 1.567 > 1.55).  The cut is at the
    # 7th state's p; the lower part holds both failures (direct 4/6), the upper none.
    sp = rate_gate.split_capped(t, s, 1.55)
    assert sp.states == (10, 6, 4, 10)
    assert sp.edges[1] == pytest.approx(16 / 30) and sp.edges[0] == t.edges[0] and sp.edges[2] == t.edges[1]
    assert sp.direct == pytest.approx((0.5, 4 / 6, 1.0, 1.0)) and sp.moved == pytest.approx((1, 1, 1, 1))
    assert sp.extra_seconds == pytest.approx((2, 2, 2, 2)) and sp.rate == t.rate
    assert sp.move_value[1] == pytest.approx((1 - 4 / 6) - 2 * t.rate) and sp.move_value[2] < 0
    # Standard errors (every move adds 2 s, so they are the gains' own): bin 0's gains, five 1s
    # of ten, sqrt(2.5 / 9 / 10) = 1/6; bin 1's, two of ten, sqrt(1.6 / 9 / 10) = 2/15; split,
    # two of its lower six, sqrt((4 / 3) / 5 / 6); no failures elsewhere.
    assert t.move_value_se == pytest.approx((1 / 6, 2 / 15, 0.0))
    assert sp.move_value_se == pytest.approx((1 / 6, np.sqrt(4 / 90), 0.0, 0.0))
    assert rate_gate.moves_summary(sp)["moving_bins"] == [0, 1]
    assert rate_gate.motion_number(sp, np.asarray(sp.move_value) > 0) == pytest.approx(46 / 30)
    # The decision moves exactly the 16 lowest states.
    assert rate_gate.moves_at(sp, s["p_direct"]).tolist() == [True] * 16 + [False] * 14
    # A cap every whole-bin choice already meets, or no cap, leaves the table as capped does.
    assert rate_gate.split_capped(t, s, 1.7).move_value == t.move_value
    assert rate_gate.split_capped(t, s, 0.0) is t
    # A cut never separates equal p: with the 6th and 7th equal, m = 6 cannot be cut, m = 5 is
    # over the cap (45 / 29), and m = 4 (44 / 29 = 1.517) is taken.
    p = np.arange(30) / 30.0
    p[16] = p[15]
    s2 = _split_states(p)
    assert rate_gate.split_capped(_fit(s2), s2, 1.55).states == (10, 4, 6, 10)


def test_a_loaded_cap_splits_only_with_the_states_the_table_was_fit_on(tmp_path):
    s = _split_states()
    t = _fit(s)
    d = str(tmp_path)
    rate_gate.save(d, t, {"networks": "stage3 step 8"})
    assert rate_gate.load_table(d, max_motion_number=1.55).states == (10, 10, 10)  # no states: whole bins
    np.savez(os.path.join(d, rate_gate.STATES_FILE), **s)
    assert rate_gate.states_match(t, rate_gate.read_states(d))
    assert rate_gate.load_table(d, max_motion_number=1.55).states == (10, 6, 4, 10)
    assert rate_gate.load(d, max_motion_number=1.55).shape == (2, 4)
    assert rate_gate.load_table(d, max_motion_number=1.55, split=False).states == (10, 10, 10)
    assert rate_gate.load_table(d).states == (10, 10, 10)  # no cap: the table as measured
    # States that are not the table's (here one missing) are not used: whole bins.
    np.savez(os.path.join(d, rate_gate.STATES_FILE), **{k: v[1:] for k, v in s.items()})
    assert not rate_gate.states_match(t, rate_gate.read_states(d))
    assert rate_gate.load_table(d, max_motion_number=1.55).states == (10, 10, 10)


def test_the_split_cap_needs_every_column_it_splits():
    # States saved without the objects knocked off cannot give a table that records them its
    # split parts: the cap drops whole bins there.
    s = _split_states()
    t = _fit(s)
    short = {k: v for k, v in s.items() if k not in ("direct_lost", "moved_lost")}
    assert rate_gate.split_capped(t, short, 1.55).states == (10, 10, 10)
    assert rate_gate.split_capped(t, s, 1.55).lost_direct == pytest.approx((0, 0, 0, 0))
