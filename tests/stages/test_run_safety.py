"""The run lock (one process per run directory) and stop requests (Ctrl-C / SIGTERM)."""
import json
import os
import signal
import subprocess
import sys
import time

import pytest

from vags_jax.stages.interrupts import StopRequests
from vags_jax.stages.run_lock import LOCK_FILE, RunLock, RunLockedError

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
HOLD = ("import sys, time; sys.path.insert(0, {root!r}); from vags_jax.stages.run_lock import RunLock; "
        "lock = RunLock({run!r}).acquire(); print('held', flush=True); time.sleep(60)")


def _holder(run):
    p = subprocess.Popen([sys.executable, "-c", HOLD.format(root=ROOT, run=run)], stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "held"
    return p


def test_a_second_process_refuses_naming_the_holder(tmp_path):
    run = str(tmp_path / "run")
    p = _holder(run)
    try:
        with pytest.raises(RunLockedError, match=rf"{run} is in use by pid {p.pid} on .* choose another --out"):
            RunLock(run).acquire()
    finally:
        p.terminate()
        p.wait()


def test_a_lock_left_by_a_killed_process_is_taken_over_with_a_message(tmp_path):
    run = str(tmp_path / "run")
    p = _holder(run)
    p.kill()  # no clean release: the file still names it
    p.wait()
    said = []
    with RunLock(run, log=said.append):
        with open(os.path.join(run, LOCK_FILE)) as f:
            assert json.load(f)["pid"] == os.getpid()
    assert len(said) == 1 and f"left by pid {p.pid}" in said[0] and "no longer running" in said[0]
    said.clear()
    with RunLock(run, log=said.append):  # a clean release left nothing to take over
        pass
    assert said == []


def test_the_lock_is_released_on_exit_and_on_an_exception(tmp_path):
    run = str(tmp_path / "run")
    with pytest.raises(ZeroDivisionError):
        with RunLock(run):
            1 / 0
    with RunLock(run):
        with pytest.raises(RunLockedError):
            RunLock(run).acquire()
    RunLock(run).acquire().release()


@pytest.mark.parametrize("sig,code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_signal_becomes_a_stop_request_and_handlers_are_restored(sig, code):
    before = signal.getsignal(sig)
    with StopRequests() as stop:
        assert not stop.requested
        os.kill(os.getpid(), sig)
        time.sleep(0.05)  # the handler runs between bytecodes
        assert stop.requested and stop.exit_code == code
        os.kill(os.getpid(), signal.SIGTERM)  # a later SIGTERM changes nothing
        time.sleep(0.05)
        assert stop.exit_code == code
    assert signal.getsignal(sig) is before


def test_a_second_ctrl_c_abandons_at_once():
    with pytest.raises(KeyboardInterrupt):
        with StopRequests() as stop:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.05)
            assert stop.signal == "SIGINT"
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.05)


def test_a_second_ctrl_c_waits_for_a_protected_block():
    """A checkpoint being written is not cut: the second Ctrl-C is held to the block's end."""
    finished = []
    with pytest.raises(KeyboardInterrupt):
        with StopRequests() as stop:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.05)
            with stop.protected():
                os.kill(os.getpid(), signal.SIGINT)
                time.sleep(0.05)
                finished.append("block")
            finished.append("after")  # not reached: the held interrupt is raised as the block ends
    assert finished == ["block"]
    assert stop.abandoned_line() == "interrupted before its first checkpoint; nothing of it was saved"
    stop.at("stage2", 6)
    assert stop.abandoned_line() == "interrupted at stage2 iteration 6; --resume continues"


@pytest.mark.parametrize("argv", [["--config", "tiny"], ["--config", "tiny", "--stage", "gdnet"],
                                  ["--config", "tiny", "--stage", "ggcnn"]], ids=["pipeline", "stage1", "ggcnn"])
def test_train_refuses_a_run_directory_another_process_holds(argv, tmp_path, capsys):
    """A second train.py on the same --out: one line naming the holder, exit code 2, before
    anything is built or written (the directory holds only the holder's lock)."""
    import train

    run = str(tmp_path / "run")
    p = _holder(run)
    try:
        assert train.main(argv + ["--out", run, "--quiet"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("train.py: error: ") and f"in use by pid {p.pid}" in err[0]
        assert os.listdir(run) == [LOCK_FILE]
    finally:
        p.terminate()
        p.wait()
