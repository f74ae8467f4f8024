"""bench/pipeline_times.py on a hand-made driver folder: wall clocks from the machine log, stage
times and compiling from timings.jsonl, the compile-ahead children, runs that did not run."""
import json
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "bench"))
from pipeline_times import main, table, wall_clocks  # noqa: E402


def _folder(tmp_path):
    (tmp_path / "machine_log.txt").write_text(
        "start 04:57:55 H100\ntrain_f44 rc=0 385 s 05:04:20\nheadroom_f44 rc=0 40 s\n"
        "train_w45_auto rc=0 261 s 05:10:59\ntrain_w46_off rc=1 12 s 05:11:11\n")
    rows = [{"stage": s, "wall_s": w, "compile": {"seconds": c, "compiled": 1, "loaded": 2}}
            for s, w, c in (("stage1", 197.3, 40.0), ("stage2", 64.9, 10.0), ("stage3", 74.0, 0.0), ("gate", 35.9, 4.2))]
    rows.append({"stage": "compile_ahead", "status": "done", "wall_s": 79.4, "compile": {"compiled": 18, "loaded": 93}})
    rows.append({"stage": "compile_ahead_gate", "status": "exit code -11", "wall_s": 51.7})  # died before its report
    (tmp_path / "f44").mkdir()
    (tmp_path / "f44" / "timings.jsonl").write_text("\n".join(json.dumps(r) for r in rows) + "\n")
    return tmp_path


def test_rows_from_the_log_and_timings(tmp_path):
    d = _folder(tmp_path)
    assert wall_clocks(str(d / "machine_log.txt")) == {"f44": 385, "w45": 261}  # w46 failed: no wall clock
    lines = table(str(d), [("f44", "cold"), ("w45", "")]).splitlines()
    assert lines[2] == ("| f44, cold | 385 | 197.3 | 64.9 | 74.0 | 35.9 | 54.2 | done, 18 compiled, 93 loaded, 79 s"
                        " / exit code -11, 52 s |")
    assert lines[3] == "| w45 | not run | | | | | | |"  # no timings.jsonl kept


def test_a_folder_without_a_machine_log_is_refused(tmp_path, capsys):
    assert main([str(tmp_path), "f44"]) == 2
    assert "has no machine_log.txt" in capsys.readouterr().err
    assert main([str(_folder(tmp_path)), "f44=cold"]) == 0
    assert "| f44, cold | 385 |" in capsys.readouterr().out
