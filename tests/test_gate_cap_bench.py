"""bench/gate_cap.py: the rate gate's moves under motion-number caps, on a hand-made gate.json."""
import os
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "bench"))
import gate_cap  # noqa: E402

from vags_jax.policies import rate_gate  # noqa: E402


def test_gate_cap_tabulates_each_tables_moves_per_cap(tmp_path, capsys):
    # Bins of 10 states: direct 0.4 / 0.7, after a move 0.9 / 0.8; both move.  No cap: 40 motions
    # over 17 grasped objects = 2.353, success 0.85; cap 2.2: bin 1 (gain 0.1) goes, 30 / 16 = 1.875,
    # success 0.8; cap 1.5: bin 0 too, 20 / 11 = 1.818 (still over, nothing left to drop), 0.55.
    t = rate_gate.GateTable(edges=(0.5,), states=(10, 10), direct=(0.4, 0.7), moved=(0.9, 0.8),
                            extra_seconds=(1.0, 1.0), rate=0.1, move_value=(0.3, 0.01))
    path = rate_gate.save(str(tmp_path), t, {"networks": "stage3 step 8"})
    assert gate_cap.main([path, "--caps", "2.2,1.5"]) == 0
    out = capsys.readouterr().out
    assert f"| {path} | [0, 1] | 2.353 | 85.0 | [0] | 1.875 | 80.0 | [] | 1.818 | 55.0 |" in out
    for bad in ("0.5", "x"):
        with pytest.raises(SystemExit) as e:
            gate_cap.main([path, "--caps", bad])
        assert e.value.code == 2


def test_gate_cap_refits_the_measured_states_in_finer_bins(tmp_path, capsys):
    """--bins K fits the table again from the gate_states.npz beside it; with the states there,
    each setting also gets the success on 6+ object states and the one-object states moved."""
    import numpy as np

    from vags_jax.stages import gate_measure

    # p below 0.5: direct 1 of 4, after a move 4 of 4 (one more second); above: 4 of 4 both.
    p = np.array([0.1, 0.2, 0.3, 0.4, 0.6, 0.7, 0.8, 0.9])
    states = {"p_direct": p, "direct_success": np.array([0, 0, 1, 0, 1, 1, 1, 1.0]), "moved_success": np.ones(8),
              "direct_seconds": np.full(8, 5.0), "moved_seconds": np.full(8, 6.0), "direct_lost": np.zeros(8),
              "moved_lost": np.zeros(8), "objects": np.array([1, 1, 6, 6, 1, 6, 6, 6])}
    np.savez(tmp_path / gate_measure.STATES_FILE, **states)
    one_bin = rate_gate.fit(p, states["direct_success"], states["direct_seconds"], states["moved_success"],
                            states["moved_seconds"], 1)
    path = rate_gate.save(str(tmp_path), one_bin, {"networks": "stage3 step 8"})
    assert gate_cap.main([path, "--bins", "2", "--caps", "1.2"]) == 0
    out = capsys.readouterr().out
    # 2 bins: the lower one moves (12 motions / 8 grasped); its one-object states 2 of 3 moved.
    # Cap 1.2: nothing moves, 8 / 5 = 1.6; 6+ objects 4 of 5 grasped.
    assert f"| {path} | [0] | 1.500 | 100.0 | 100.0 | 66.7 | [] | 1.600 | 62.5 | 80.0 | 0.0 |" in out
    alone = tmp_path / "alone"
    alone.mkdir()
    other = rate_gate.save(str(alone), one_bin, {})
    assert gate_cap.main([other, "--bins", "2"]) == 2
    assert "no measured gate table" in capsys.readouterr().err
    with pytest.raises(SystemExit) as e:
        gate_cap.main([path, "--bins", "-1"])
    assert e.value.code == 2


def test_gate_cap_splits_a_bin_where_the_states_allow(tmp_path, capsys):
    """With the measured states beside the table, a cap splits the last bin it drops, as eval.py
    does; --whole-bins drops it whole."""
    import numpy as np

    # Two bins of 4: direct 1 of 4 and 3 of 4 (failing at p 0.6), after a move 4 of 4 both.
    p = np.array([0.1, 0.2, 0.3, 0.4, 0.6, 0.7, 0.8, 0.9])
    states = {"p_direct": p, "direct_success": np.array([0, 0, 1, 0, 0, 1, 1, 1.0]), "moved_success": np.ones(8),
              "direct_seconds": np.full(8, 5.0), "moved_seconds": np.full(8, 5.5), "direct_lost": np.zeros(8),
              "moved_lost": np.zeros(8), "objects": np.full(8, 6)}
    np.savez(tmp_path / rate_gate.STATES_FILE, **states)
    t = rate_gate.fit(p, states["direct_success"], states["direct_seconds"], states["moved_success"],
                      states["moved_seconds"], 2)
    path = rate_gate.save(str(tmp_path), t, {"networks": "stage3 step 8"})
    # Both bins move: 16 / 8 = 2.0.  Cap 1.7, whole bins: bin 1 (gain 0.25) goes, 12 / 7 = 1.714,
    # then bin 0, 8 / 4 = 2.0: nothing moves.  Split: bin 1's lowest state (p 0.6, a failure)
    # moves, on top of bin 0: 13 / 8 = 1.625.
    assert gate_cap.main([path, "--caps", "1.7"]) == 0
    assert f"| {path} | [0, 1] | 2.000 | 100.0 | 100.0 | | [0, 1] | 1.625 | 100.0 | 100.0 |" in \
        capsys.readouterr().out.replace(" nan |", " |").replace("|  |", "| |")
    assert gate_cap.main([path, "--caps", "1.7", "--whole-bins"]) == 0
    assert f"| {path} | [0, 1] | 2.000 | 100.0 | 100.0 | | [] | 2.000 | 50.0 | 50.0 |" in \
        capsys.readouterr().out.replace(" nan |", " |").replace("|  |", "| |")


def test_gate_cap_drops_the_moves_within_the_noise_first(tmp_path, capsys):
    """--min-z Z: the moves within Z standard errors of 0 go before any cap, as eval.py's
    vags.gate_min_z; a table without errors is refused in one line (exit 2), a bad Z too."""
    # The first test's table with errors: bin 1's +0.01 is within 2 x 0.02 of 0, bin 0's is not.
    t = rate_gate.GateTable(edges=(0.5,), states=(10, 10), direct=(0.4, 0.7), moved=(0.9, 0.8),
                            extra_seconds=(1.0, 1.0), rate=0.1, move_value=(0.3, 0.01), move_value_se=(0.02, 0.02))
    path = rate_gate.save(str(tmp_path), t, {"networks": "stage3 step 8"})
    assert gate_cap.main([path, "--caps", "2.2", "--min-z", "2"]) == 0
    # Bin 1 is dropped already: 30 motions / 16 grasped = 1.875 at 80 % with or without the cap.
    assert f"| {path} | [0] | 1.875 | 80.0 | [0] | 1.875 | 80.0 |" in capsys.readouterr().out
    assert gate_cap.main([path, "--caps", "2.2", "--min-z", "0.4"]) == 0  # 0.01 is above 0.4 x 0.02
    assert f"| {path} | [0, 1] | 2.353 | 85.0 |" in capsys.readouterr().out
    old = tmp_path / "old"
    old.mkdir()
    bare = rate_gate.save(str(old), rate_gate.GateTable(**{**t.__dict__, "move_value_se": ()}), {})
    assert gate_cap.main([bare, "--min-z", "2"]) == 2
    assert "no standard errors" in capsys.readouterr().err
    with pytest.raises(SystemExit) as e:
        gate_cap.main([path, "--min-z", "-1"])
    assert e.value.code == 2
