"""One process per run directory: an advisory lock on ``RUN/run.lock``.

``train.py`` holds the lock of its ``--out`` for its whole life, so a second training started
into the same directory refuses at once, in one line naming the holder, instead of both writing
checkpoints into one folder.  The lock is an ``flock`` on the open file, so the operating
system releases it when the holder exits in any way (a crash or ``kill -9`` included).  The
file holds the holder as JSON (pid, host, start time, command line) and is emptied on a clean
release, so a holder that ended without releasing is named when the next run takes it over.
"""
from __future__ import annotations

import datetime
import fcntl
import json
import os
import socket
import sys
from typing import Callable, Optional

LOCK_FILE = "run.lock"


class RunLockedError(RuntimeError):
    """Another live process holds the run directory's lock (message: who, and what to do)."""


def _holder(path: str) -> dict:
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except (OSError, ValueError):
        return {}


def _describe(h: dict) -> str:
    if not h:
        return "another process"
    cmd = " ".join(h.get("argv", []))[:120]
    return f"pid {h.get('pid')} on {h.get('host')} since {h.get('started')} ({cmd})"


class RunLock:
    """``with RunLock(run_dir): ...`` holds ``run_dir/run.lock`` (the directory is created).

    Raises RunLockedError when a live process holds it.  ``log`` gets one line when a lock
    left by a process that is gone is taken over."""

    def __init__(self, run_dir: str, log: Optional[Callable[[str], None]] = None):
        self.run_dir = run_dir
        self.path = os.path.join(run_dir, LOCK_FILE)
        self.log = log or (lambda s: print(s, file=sys.stderr))
        self._fd: Optional[int] = None

    def acquire(self) -> "RunLock":
        os.makedirs(self.run_dir, exist_ok=True)
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            raise RunLockedError(
                f"{self.run_dir} is in use by {_describe(_holder(self.path))}: wait for it to finish or stop "
                f"it, or choose another --out") from None
        old = _holder(self.path)
        if old:  # a clean release empties the file: this holder ended without releasing
            self.log(f"taking over the lock of {self.run_dir} left by {_describe(old)}, which is no longer running")
        info = {"pid": os.getpid(), "host": socket.gethostname(),
                "started": datetime.datetime.now().isoformat(timespec="seconds"), "argv": sys.argv}
        os.ftruncate(fd, 0)
        os.pwrite(fd, json.dumps(info).encode(), 0)
        self._fd = fd
        return self

    def release(self) -> None:
        """Empty the file, then unlock (the file stays: removing it would let two processes lock
        two different files of the same name)."""
        if self._fd is None:
            return
        os.ftruncate(self._fd, 0)
        fcntl.flock(self._fd, fcntl.LOCK_UN)
        os.close(self._fd)
        self._fd = None

    def __enter__(self) -> "RunLock":
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()


__all__ = ["LOCK_FILE", "RunLock", "RunLockedError"]
