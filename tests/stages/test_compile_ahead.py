"""``stages/compile_ahead.py`` (train.py --compile-ahead): when the pipeline starts the threads,
their life (started once, waited for, a failure only warned about) with stand-in work, and on a
tiny pipeline that stage 2 and the gate table then compile nothing of the programs built ahead."""
import os
import threading
import time
from types import SimpleNamespace

import pytest

from vags_jax import config as C
from vags_jax.compile_cache import CompileClock
from vags_jax.stages import compile_ahead, driver, rundir


def test_why_not_needs_a_gpu_unless_forced():
    assert compile_ahead.why_not("off", "gpu") == "off"
    assert "on a CPU" in compile_ahead.why_not("auto", "cpu")
    assert compile_ahead.why_not("auto", "gpu") is None
    assert compile_ahead.why_not("on", "cpu") is None


def test_the_thread_is_started_once_waited_for_and_its_report_and_compiles_kept():
    lines, threads, release = [], [], threading.Event()

    def work():
        threads.append(threading.get_ident())
        release.wait(10)
        import jax
        import jax.numpy as jnp
        jax.jit(lambda x: x * 3 + 1).lower(jnp.zeros((7, 5))).compile()  # a program of its own
        return {"stage2": "report"}

    ahead = compile_ahead.CompileAhead(work, log=lines.append)
    assert ahead.finish() == {"status": "not started"}
    with CompileClock() as here:
        ahead.start()
        ahead.start()  # a second call starts nothing
        release.set()
        got = ahead.finish()
    assert len(threads) == 1 and threads[0] != threading.get_ident()
    assert got["status"] == "done" and got["wall_s"] >= 0 and got["waited_s"] >= 0
    assert got["report"] == {"stage2": "report"}
    # The thread's compile is its clock's, not the clock of the thread that waited for it.
    assert got["compile"]["compiled"] + got["compile"]["loaded"] >= 1
    assert here.compiled == 0 and here.loaded == 0
    assert "in a thread" in lines[0] and "ready after" in lines[-1]


def test_a_failed_thread_is_a_warning_and_the_pipeline_goes_on():
    lines = []

    def work():
        raise ValueError("no such shape\nsecond line")

    ahead = compile_ahead.CompileAhead(work, log=lines.append)
    ahead.start()
    got = ahead.finish()
    assert got["status"] == "error: ValueError: no such shape" and "report" not in got
    assert lines[-1].startswith("warning: compile ahead: stage 2's programs failed (error: ValueError")
    assert lines[-1].endswith("they compile when needed")


def test_close_says_when_the_pipeline_ends_before_the_thread():
    lines, release = [], threading.Event()
    ahead = compile_ahead.CompileAhead(lambda: release.wait(10) and {}, log=lines.append)
    ahead.start()
    ahead.close()
    assert "ends with the process" in lines[-1]
    release.set()
    ahead.finish()


def _args(out, mode, **kw):
    return SimpleNamespace(out=out, compile_ahead=mode, cache_dir=None, chunk=None, **kw)


_PROGRAMS = SimpleNamespace()  # the selection tests build nothing


@pytest.mark.parametrize("mode, only, started", [
    ("on", None, True),        # the whole pipeline, stage 1 to train here, stage 2 not begun
    ("auto", None, False),     # this suite runs on a CPU
    ("off", None, False),
    ("on", "stage2", False),   # stage 2 alone: nothing to overlap with
])
def test_the_pipeline_compiles_ahead_only_where_stage_1_trains_before_stage_2(tmp_path, tiny_cfg, mode, only,
                                                                             started):
    ahead = driver._compile_ahead(_args(str(tmp_path), mode), tiny_cfg, only, _PROGRAMS)
    assert (ahead is not None) == started
    if started:
        assert ahead.thread is None  # started by stage 1's first chunk, not before


@pytest.mark.parametrize("mode, only, worlds, started", [
    ("on", None, 4, True),      # the whole pipeline measures the table after stage 3
    ("on", None, 0, False),     # gate_table.worlds=0: no table to measure
    ("auto", None, 4, False),   # this suite runs on a CPU
    ("on", "stage3", 4, False),  # one stage alone measures no table
])
def test_the_gate_tables_program_compiles_ahead_only_where_the_pipeline_measures_it(tmp_path, tiny_cfg, mode,
                                                                                    only, worlds, started):
    cfg = C.replace(tiny_cfg, **{"gate_table.worlds": worlds})
    ahead = driver._compile_gate_ahead(_args(str(tmp_path), mode), cfg, only, _PROGRAMS)
    assert (ahead is not None) == started
    if started:
        assert ahead.thread is None and "gate" in ahead.what


class _StandIn:
    """A compile-ahead thread that records when the pipeline starts and waits for it."""

    def __init__(self, name, events):
        self.name, self.events, self.started = name, events, False

    def start(self):
        if not self.started:
            self.started = True
            self.events.append(f"start {self.name}")

    def finish(self):
        self.events.append(f"finish {self.name}")
        return {"status": "done", "wall_s": 1.0, "waited_s": 0.0, "compile": {"compiled": 1}, "report": {}}


def test_the_pipeline_starts_each_thread_after_a_first_chunk_and_waits_before_its_programs_run(tmp_path, tiny_cfg,
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
