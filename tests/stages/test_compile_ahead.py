"""``stages/compile_ahead.py`` (train.py --compile-ahead): when the pipeline starts the second
process, its command line, and the process's life (started once, waited for, a failure only
warned about, ended on a stop), with stand-in commands instead of the real precompile."""
import os
import sys
import time
from types import SimpleNamespace

import pytest

from vags_jax import compile_cache
from vags_jax.stages import compile_ahead, driver


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


def _child(tmp_path, code: str, lines: list):
    run = str(tmp_path)
    return compile_ahead.CompileAhead(run, [sys.executable, "-c", code], log=lines.append)


def test_the_child_is_started_once_waited_for_and_its_report_kept(tmp_path):
    lines = []
    code = ("import os, json; print('compiling'); "
            "print(json.dumps({'stage2': {'prealloc': os.environ['XLA_PYTHON_CLIENT_PREALLOCATE']}}))")
    ahead = _child(tmp_path, code, lines)
    assert ahead.finish() == {"status": "not started"}
    ahead.start()
    pid = ahead.proc.pid
    ahead.start()  # a second call starts nothing
    assert ahead.proc.pid == pid
    got = ahead.finish()
    assert got["status"] == "done" and got["wall_s"] >= got["waited_s"] >= 0
    assert got["report"] == {"stage2": {"prealloc": "false"}}  # it allocates device memory on demand
    with open(os.path.join(str(tmp_path), compile_ahead.LOG_FILE)) as f:
        assert f.read().startswith("compiling")
    assert "second process" in lines[0] and "ready after" in lines[-1]


def test_a_failed_child_is_a_warning_and_the_pipeline_goes_on(tmp_path):
    lines = []
    ahead = _child(tmp_path, "import sys; sys.exit(3)", lines)
    ahead.start()
    got = ahead.finish()
    assert got["status"] == "exit code 3" and "report" not in got
    assert lines[-1].startswith("warning: compile ahead: the second process ended with exit code 3")
    assert "stage 2 compiles its own programs" in lines[-1]


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
