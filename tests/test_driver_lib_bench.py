"""bench/driver_lib.sh's functions in bash: run's log line (as bench/pipeline_times.py reads it)
and status, a caller's variables surviving run and keep, and keep's copies."""
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
LIB = os.path.join(os.path.dirname(HERE), "bench", "driver_lib.sh")
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "bench"))
from pipeline_times import wall_clocks  # noqa: E402


def _bash(script: str, res) -> str:
    out = subprocess.run(["bash", "-c", f"RES={res}; source {LIB}; {script}"], capture_output=True, text=True,
                         check=True)
    return out.stdout


def test_run_logs_and_keeps_the_callers_variables(tmp_path):
    res = tmp_path / "res"
    got = _bash("for t in full half; do run train_s47$t echo hi; echo $t; done; "
                "run train_f1 false; echo rc=$?; key=mine; run x true; echo $key", res)
    assert got.split() == ["full", "half", "rc=1", "mine"]
    log = (res / "machine_log.txt").read_text().splitlines()
    assert [line.split()[:2] for line in log] == [["train_s47full", "rc=0"], ["train_s47half", "rc=0"],
                                                  ["train_f1", "rc=1"], ["x", "rc=0"]]
    assert (res / "train_s47half.txt").read_text() == "hi\n"
    clocks = wall_clocks(str(res / "machine_log.txt"))  # the runs that exited 0, by run name
    assert list(clocks) == ["s47"] and clocks["s47"] in (0, 1)  # seconds: a clock tick may fall inside


def test_keep_copies_a_runs_small_files(tmp_path):
    run = tmp_path / "run"
    (run / "stage2").mkdir(parents=True)
    for name in ("config.json", "gate.json", "checkpoint.bin"):
        (run / name).write_text(name)
    (run / "stage2" / "metrics.jsonl").write_text("{}")
    got = _bash(f"t=half; keep {run} {tmp_path}/kept; echo $t", tmp_path / "res")
    assert got.split() == ["half"]
    assert sorted(os.listdir(tmp_path / "kept")) == ["config.json", "gate.json", "stage2_metrics.jsonl"]
