"""``stages/compile_ahead.py`` (train.py --compile-ahead): when the pipeline starts the second
process, its command line, and the process's life (started once, waited for, a failure only
warned about, ended on a stop), with stand-in commands instead of the real precompile."""
import json
import os
import sys
import time
from types import SimpleNamespace

import pytest

from vags_jax import compile_cache
from vags_jax import config as C
from vags_jax.stages import compile_ahead, driver, rundir


def test_why_not_needs_the_shared_cache_and_a_gpu_unless_forced():
    assert compile_ahead.why_not("off", None, "gpu") == "off"
    assert "no compile cache" in compile_ahead.why_not("on", "off", "gpu")
    assert "on a CPU" in compile_ahead.why_not("auto", None, "cpu")
    # The suite's cache (conftest: $VAGS_JAX_CACHE_DIR) is the one this process compiles into.
    assert compile_ahead.cache_root(None) == compile_cache.resolve(None)
    assert compile_ahead.why_not("auto", None, "gpu") is None
    assert compile_ahead.why_not("on", None, "cpu") is None
    # A --cache-dir other than the one this process uses cannot be shared.
    assert compile_ahead.cache_root("/somewhere/else") is None


def test_the_command_precompiles_stage_2_of_the_run_into_the_cache():
    argv = compile_ahead.command("runs/r", "/c", 5)
    assert argv[:3] == [sys.executable, "-m", "vags_jax.stages.precompile"]
    assert argv[3:] == ["--run", "runs/r", "--stages", "stage2", "--cache-dir", "/c", "--json", "--chunk", "5"]
    assert "--chunk" not in compile_ahead.command("runs/r", "/c", None)
    gate = compile_ahead.command("runs/r", "/c", None, stages="gate")
    assert gate[gate.index("--stages") + 1] == "gate"


def _child(tmp_path, code: str, lines: list):
    run = str(tmp_path)
    return compile_ahead.CompileAhead(run, [sys.executable, "-c", code], log=lines.append)


def test_the_child_is_started_once_waited_for_and_its_report_kept(tmp_path):
    lines = []
    code = ("import os, json; print('compiling'); "
            "print(json.dumps({'stage2': {'prealloc': os.environ['XLA_PYTHON_CLIENT_PREALLOCATE'], "
            "'allocator': os.environ.get('XLA_PYTHON_CLIENT_ALLOCATOR')}}))")
    ahead = _child(tmp_path, code, lines)
    assert ahead.finish() == {"status": "not started"}
    ahead.start()
    pid = ahead.proc.pid
    ahead.start()  # a second call starts nothing
    assert ahead.proc.pid == pid
    got = ahead.finish()
    assert got["status"] == "done" and got["wall_s"] >= got["waited_s"] >= 0
    # It takes device memory buffer by buffer, not in a pool's growing regions (out of memory on an H100).
    assert got["report"] == {"stage2": {"prealloc": "false", "allocator": "platform"}}
    with open(os.path.join(str(tmp_path), compile_ahead.LOG_FILE)) as f:
        assert f.read().startswith("compiling")
    assert "second process" in lines[0] and "ready after" in lines[-1]


def test_a_failed_child_is_a_warning_and_the_pipeline_goes_on(tmp_path):
    lines = []
    ahead = _child(tmp_path, "import sys; print('RuntimeError: out of memory', flush=True); sys.exit(3)", lines)
    ahead.start()
    got = ahead.finish()
    assert got["status"] == "exit code 3" and "report" not in got
    assert lines[-1].startswith("warning: compile ahead: the second process ended with exit code 3")
    assert "its last line: 'RuntimeError: out of memory'" in lines[-1]  # why, without opening the log
    assert got["last_line"] == "RuntimeError: out of memory"  # kept in the run's timings
    assert "stage 2's programs compile when needed" in lines[-1]


def test_a_child_out_of_device_memory_is_named_as_such(tmp_path):
    """A child whose log reports running out of device memory, before a last line that does not
    (as on an H100: Warp then fails to load a module), is named as out of memory; another error is not."""
    lines = []
    oom = ("print('E cuda_executor.cc] Failed to allocate device memory: CUDA_ERROR_OUT_OF_MEMORY'); "
           "print('Exception: Failed to load CUDA module', flush=True); raise SystemExit(1)")
    ahead = _child(tmp_path, oom, lines)
    ahead.start()
    got = ahead.finish()
    assert got["out_of_memory"] and got["last_line"] == "Exception: Failed to load CUDA module"
    assert "it ran out of device memory" in lines[-1] and "preallocated pool" in lines[-1]
    lines.clear()
    other = _child(tmp_path, "print('ValueError: bad config', flush=True); raise SystemExit(1)", lines)
    other.start()
    got = other.finish()
    assert "out_of_memory" not in got and "device memory" not in lines[-1]


def test_a_failed_childs_error_is_kept_in_the_runs_timings(tmp_path):
    """train.py's timings.jsonl row for a failed child carries its last log line."""
    lines = []
    ahead = _child(tmp_path, "print('XlaRuntimeError: RESOURCE_EXHAUSTED', flush=True); raise SystemExit(1)", lines)
    ahead.start()
    driver._finish_ahead(SimpleNamespace(out=str(tmp_path)), ahead, "compile_ahead", "stage2")
    with open(os.path.join(str(tmp_path), "timings.jsonl")) as f:
        row = json.loads(f.read().splitlines()[-1])
    assert (row["stage"], row["status"]) == ("compile_ahead", "exit code 1")
    assert row["last_line"] == "XlaRuntimeError: RESOURCE_EXHAUSTED" and row["out_of_memory"] is True


def test_a_child_that_cannot_start_is_a_warning(tmp_path):
    lines = []
    ahead = compile_ahead.CompileAhead(str(tmp_path), [str(tmp_path / "no-such-program")], log=lines.append)
    ahead.start()
    assert ahead.proc is None and lines[-1].startswith("warning: compile ahead: could not start")
    assert ahead.finish() == {"status": "not started"}


def test_close_ends_a_child_still_running(tmp_path):
    ahead = _child(tmp_path, "import time; time.sleep(60)", [])
    ahead.start()
    t0 = time.time()
    ahead.close()
    assert ahead.proc.poll() is not None and time.time() - t0 < 15


def _args(out, mode, **kw):
    return SimpleNamespace(out=out, compile_ahead=mode, cache_dir=None, chunk=None, **kw)


@pytest.mark.parametrize("mode, only, started", [
    ("on", None, True),        # the whole pipeline, stage 1 to train here, stage 2 not begun
    ("auto", None, False),     # this suite runs on a CPU
    ("off", None, False),
    ("on", "stage2", False),   # stage 2 alone: nothing to overlap with
])
def test_the_pipeline_compiles_ahead_only_where_stage_1_trains_before_stage_2(tmp_path, tiny_cfg, mode, only,
                                                                             started):
    ahead = driver._compile_ahead(_args(str(tmp_path), mode), tiny_cfg, only)
    assert (ahead is not None) == started
    if started:
        assert ahead.argv[ahead.argv.index("--run") + 1] == str(tmp_path)
        assert ahead.proc is None  # started by stage 1's first chunk, not before


@pytest.mark.parametrize("mode, only, worlds, started", [
    ("on", None, 4, True),      # the whole pipeline measures the table after stage 3
    ("on", None, 0, False),     # gate_table.worlds=0: no table to measure
    ("auto", None, 4, False),   # this suite runs on a CPU
    ("on", "stage3", 4, False),  # one stage alone measures no table
])
def test_the_gate_tables_program_compiles_ahead_only_where_the_pipeline_measures_it(tmp_path, tiny_cfg, mode,
                                                                                    only, worlds, started):
    cfg = C.replace(tiny_cfg, **{"gate_table.worlds": worlds})
    child = driver._compile_gate_ahead(_args(str(tmp_path), mode), cfg, only)
    assert (child is not None) == started
    if started:
        assert child.argv[child.argv.index("--stages") + 1] == "gate" and child.proc is None
        assert child.log_path == os.path.join(str(tmp_path), compile_ahead.GATE_LOG_FILE)


class _StandIn:
    """A compile-ahead child that records when the pipeline starts and waits for it."""

    def __init__(self, name, events):
        self.name, self.events, self.started = name, events, False

    def start(self):
        if not self.started:
            self.started = True
            self.events.append(f"start {self.name}")

    def finish(self):
        self.events.append(f"finish {self.name}")
        return {"status": "done", "wall_s": 1.0, "waited_s": 0.0, "report": {self.name: {"compile": {"compiled": 1}}}}


def test_the_pipeline_starts_each_child_after_a_first_chunk_and_waits_before_its_programs_run(tmp_path, tiny_cfg,
                                                                                              monkeypatch):
    events = []

    def run_stage(cfg, args, name, done, h, deadline, programs, arrays, stop, board, first, deferred):
        events.append(f"run {name}")
        if first is not None:
            first()  # the stage's first chunk has run
        return {"stage": name, "iterations": rundir.total(cfg, name)}, h

    monkeypatch.setattr(driver, "run_stage", run_stage)
    monkeypatch.setattr(driver, "measure_gate", lambda args, cfg, programs: events.append("measure gate") or {})
    monkeypatch.setattr(driver.gate_measure, "due", lambda *a: True)
    monkeypatch.setattr(driver, "report_end", lambda *a, **k: None)
    args = _args(str(tmp_path), "on", quiet=True, max_minutes=None)
    stop = SimpleNamespace(requested=False, protected=driver.contextlib.nullcontext)
    plan = SimpleNamespace(stage1_arrays=None)
    programs = SimpleNamespace(env=lambda cfg: None)
    code = driver._pipeline_stages(args, None, plan, programs, stop, None, tiny_cfg, time.time(), None, [],
                                   driver.pipeline.Handover(), rundir.ORDER, _StandIn("stage2", events), [],
                                   _StandIn("gate", events))
    assert code == 0
    assert events == ["run stage1", "start stage2", "finish stage2", "run stage2", "start gate", "run stage3",
                      "finish gate", "measure gate"]
    with open(os.path.join(str(tmp_path), "timings.jsonl")) as f:
        rows = [ln for ln in f.read().splitlines() if ln]
    assert [r.split('"stage": "')[1].split('"')[0] for r in rows] == ["compile_ahead", "compile_ahead_gate"]
