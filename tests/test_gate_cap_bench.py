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
