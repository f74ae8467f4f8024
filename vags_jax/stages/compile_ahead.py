"""The next stages' programs compiled in a thread of train.py while a stage trains (``train.py
--compile-ahead``).

Stage 2's chunk program (which stage 3 shares) and the rate gate's table program are the
pipeline's largest.  Without this, each compiles (or loads from the compile cache) when its
stage starts, with the accelerator idle meanwhile.  Stage 1 is bound by the accelerator and
leaves the host's cores mostly free, so once its first chunk has run (its own compiling over,
Warp's kernels loaded), a thread builds stage 2's program from the shapes of its start; once
stage 2's (or a resumed stage 3's) first chunk has run, another builds the gate table's.  The
threads run nothing on the device: the starts are ``jax.eval_shape``'d (``VagsStage.init(...,
abstract=True)``, ``gate_measure.compile_collect(..., abstract_piles=True)``), and the programs
are lowered and compiled into the same ``Programs`` the pipeline then runs, so JAX finds them
in memory and the stage compiles nothing (XLA's compiler does not hold Python's lock, so stage
1's loop goes on beside it).  The compile cache on disk gets them too, as from any compile.
The pipeline waits for a thread before the stage that needs its programs.  Whatever happens to
a thread, the pipeline goes on: if it fails, the stage compiles its own programs as without it
(one warning line with the error).
"""
from __future__ import annotations

import threading
import time
from typing import Callable, Optional

from vags_jax import cli
from vags_jax.compile_cache import CompileClock

MODES = ("auto", "on", "off")


def why_not(mode: str, platform: str) -> Optional[str]:
    """None when the pipeline should compile ahead under ``mode`` (``MODES``), else why not, for
    the log: "auto" compiles ahead on an accelerator only (on a CPU the thread's compiling would
    take the cores stage 1 trains on)."""
    if mode == "off":
        return "off"
    if mode == "auto" and platform == "cpu":
        return "on a CPU stage 1 needs the cores (--compile-ahead on forces it)"
    return None


class CompileAhead:
    """``target()`` (compiles programs, -> a report dict) in a thread of its own (module
    docstring).  ``start()`` launches it (once; later calls do nothing), ``finish()`` waits for it
    and says how it went -> {"wall_s", "waited_s", "status", "compile" (the thread's
    ``CompileClock``), "report"?}; ``close()`` says so when the pipeline ends before it (a thread
    cannot be stopped: it ends with the process).  ``what`` names the programs and ``during`` what
    trains meanwhile, for the log lines.  ``prepare()``, if given, runs in the thread calling
    ``start()`` before the thread starts: eager device work the programs' tracing would otherwise
    do in the thread (the renderer's geometry for a batch size, ``Observation.prepare``)."""

    def __init__(self, target: Callable[[], dict], log: Callable[[str], None] = print,
                 what: str = "stage 2's programs", during: str = "stage 1 trains",
                 prepare: Optional[Callable[[], None]] = None):
        self.target, self.log, self.what, self.during, self.prepare = target, log, what, during, prepare
        self.thread: Optional[threading.Thread] = None
        self.t0 = 0.0
        self.wall_s = 0.0
        self.result: dict = {}

    def _run(self) -> None:
        try:
            with CompileClock() as clock:
                report = self.target()
            self.result = {"status": "done", "compile": clock.as_dict(), "report": report}
        except Exception as e:  # noqa: BLE001 -- any failure leaves the stage to compile for itself
            self.result = {"status": f"error: {type(e).__name__}: {cli.first_line(e, 300)}"}
        self.wall_s = time.time() - self.t0

    def start(self) -> None:
        if self.thread is not None:
            return
        if self.prepare is not None:
            self.prepare()
        self.t0 = time.time()
        self.thread = threading.Thread(target=self._run, name="compile-ahead", daemon=True)
        self.thread.start()
        self.log(f"compile ahead: {self.what} compiling in a thread while {self.during}")

    def finish(self) -> dict:
        """Waits for the thread (if started) -> {"wall_s", "waited_s", "status", "compile"?, "report"?}."""
        if self.thread is None:
            return {"status": "not started"}
        tw = time.time()
        if self.thread.is_alive():
            self.log(f"compile ahead: waiting for the thread to finish {self.what} ...")
        self.thread.join()
        got = {"wall_s": round(self.wall_s, 1), "waited_s": round(time.time() - tw, 1), **self.result}
        if got["status"] == "done":
            self.log(f"compile ahead: {self.what} ready after {got['wall_s']} s (waited {got['waited_s']} s for "
                     f"them)")
        else:
            self.log(f"warning: compile ahead: {self.what} failed ({got['status']}); they compile when needed")
        return got

    def close(self) -> None:
        if self.thread is not None and self.thread.is_alive():
            self.log(f"compile ahead: the pipeline ends before {self.what} compiled; the thread ends with the "
                     f"process")


__all__ = ["MODES", "why_not", "CompileAhead"]
