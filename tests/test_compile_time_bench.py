"""bench/compile_time.py on the tiny config: a report of each program's lowering, compile and
call times."""
import json
import os
import sys

import jax
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "bench"))
from compile_time import main  # noqa: E402


def test_compile_time_reports_the_forward_program(tmp_path, capsys):
    out = tmp_path / "ct.json"
    assert main(["--config", "tiny", "--programs", "forward", "--worlds", "2", "--out", str(out)]) == 0
    report = json.loads(out.read_text())
    fwd = report["programs"]["forward"]
    assert set(report["programs"]) == {"forward"} and fwd["worlds"] == 2
    assert fwd["compile_s"] > 0 and fwd["run_s"] > 0 and fwd["lower_s"] > 0 and fwd["stablehlo_lines"] > 100
    assert report["trunk"] == "small" and report["heightmap_px"] == 32 and report["rotations"] == 16
    # CPU reports XLA's buffer sizes; the 2 x 16 rotated 32 x 32 states need scratch space.
    assert fwd["temp_bytes"] > 0 and fwd["argument_bytes"] > 0
    assert report["persistent_cache"] is bool(jax.config.jax_compilation_cache_dir)  # the suite's cache (conftest)


def test_compile_time_refuses_unknown_programs_and_settings(capsys):
    with pytest.raises(SystemExit) as e:
        main(["--config", "tiny", "--programs", "update,backward"])
    assert e.value.code == 2 and "--programs" in capsys.readouterr().err
    with pytest.raises(SystemExit) as e:
        main(["--config", "tiny", "--set", "dqn.batch_size=0"])
    assert e.value.code == 2 and "batch_size" in capsys.readouterr().err
    with pytest.raises(SystemExit) as e:
        main(["--config", "tiny", "--worlds", "0"])
    assert e.value.code == 2 and "--worlds" in capsys.readouterr().err
