"""Stage 2's programs compiled in a second process while stage 1 trains (``train.py
--compile-ahead``).

On a machine whose compile cache is empty, the whole pipeline compiles stage 2's chunk program
(which stage 3 shares) only when stage 2 starts, with the accelerator idle meanwhile.  Stage 1
is bound by the accelerator and leaves the host's cores mostly free, so once its first chunk
has run (Warp's kernels then sit in the on-disk cache, and stage 1's own compiling is over) a
child process, ``python -m vags_jax.stages.precompile --run RUN --stages stage2``, builds stage
2's start and chunk program into the same compile cache.  Stage 2 then loads them instead of
compiling.  The child runs stage 2's start for real, so the device needs room for a second copy
of stage 2's worlds (not its replays, which the child only shapes) beside stage 1.  The child
takes device memory buffer by buffer and gives it back (``XLA_PYTHON_CLIENT_ALLOCATOR=platform``):
with JAX's growing pool instead (``XLA_PYTHON_CLIENT_PREALLOCATE=false`` alone) its next region
was 16 GiB, and on an H100 beside train.py's pool the attempt left too little for Warp to load
its kernels (bench/RESULTS.md, "Q-network passes only where their result is used"; with this
allocator both children of a warm H100 run finished: "The warm pipeline with
`forward_needed_only`").  The slow
allocator costs the child little: it runs stage 2's start once.  Whatever happens to the child, the pipeline goes on:
if it fails, stage 2 compiles its own programs as without it (one warning line naming the
child's log, ``RUN/compile_ahead.log``, and quoting its last line).

The rate gate's table, measured after stage 3, has its own program: a second child
(``--stages gate``, log ``RUN/compile_ahead_gate.log``) compiles it once stage 2's (or, resumed,
stage 3's) first chunk has run, and the pipeline waits for it before measuring the table.

Why a process and not a thread of train.py (which could leave the program in memory and spare
the stage its load from the cache): XLA work started by another thread of the process breaks
MuJoCo Warp's CUDA graph capture on XLA's stream ("capturing stream has unjoined work"; both
pipelines that tried it crashed in stage 1: bench/RESULTS.md, "Compiling ahead in threads ...").
A child has its own CUDA context.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from typing import Callable, List, Optional

import jax

from vags_jax import compile_cache

MODES = ("auto", "on", "off")
LOG_FILE = "compile_ahead.log"
# The child's device memory: exactly what its buffers need, returned when freed (module docstring).
CHILD_ALLOCATOR = {"XLA_PYTHON_CLIENT_PREALLOCATE": "false", "XLA_PYTHON_CLIENT_ALLOCATOR": "platform"}
GATE_LOG_FILE = "compile_ahead_gate.log"


def command(run_dir: str, cache_root: str, chunk: Optional[int], stages: str = "stage2") -> List[str]:
    """The child's command line: ``stages``' programs of ``run_dir``'s config (stage 2's start and
    chunk program, or "gate": the rate gate's table) into the cache rooted at ``cache_root``;
    ``chunk``: train.py's --chunk, if given."""
    argv = [sys.executable, "-m", "vags_jax.stages.precompile", "--run", run_dir, "--stages", stages,
            "--cache-dir", cache_root, "--json"]
    return argv + (["--chunk", str(chunk)] if chunk else [])


def cache_root(flag: Optional[str]) -> Optional[str]:
    """The cache directory this process compiles into (``compile_cache``'s layout, ``<root>/jax``)
    -> its root for the child's --cache-dir, or None when there is no cache to share (it is
    off, or the caller pointed JAX's own setting elsewhere)."""
    active = jax.config.jax_compilation_cache_dir
    root = compile_cache.resolve(flag)
    if not active or root is None or os.path.abspath(active) != os.path.join(root, "jax"):
        return None
    return root


def why_not(mode: str, flag: Optional[str], platform: str) -> Optional[str]:
    """None when stage 2 should compile ahead under ``mode`` (``MODES``), else why not, for the
    log: "auto" compiles ahead on an accelerator only (on a CPU the child would take the cores
    stage 1 trains on); both need the compile cache the child writes into."""
    if mode == "off":
        return "off"
    if cache_root(flag) is None:
        return ("there is no compile cache of train.py's to share (--cache-dir off, or JAX's cache set elsewhere), "
                "so the pipeline could not load what a second process compiled")
    if mode == "auto" and platform == "cpu":
        return "on a CPU stage 1 needs the cores (--compile-ahead on forces it)"
    return None


class CompileAhead:
    """A child process compiling programs ahead (stage 2's or the gate table's; module docstring).  ``start()`` launches it
    (once; later calls do nothing), ``finish()`` waits for it and says how it went (-> its
    report: wall time and, when it printed one, ``precompile``'s JSON report), ``close()`` ends
    it if it still runs (on an error or a stop request).  ``argv`` replaces the command (tests);
    ``what`` names the programs and ``during`` what trains meanwhile, for the log lines;
    ``log_file`` is the child's output in ``run_dir``."""

    def __init__(self, run_dir: str, argv: List[str], log: Callable[[str], None] = print,
                 what: str = "stage 2's programs", during: str = "stage 1 trains", log_file: str = LOG_FILE):
        self.run_dir, self.argv, self.log = run_dir, argv, log
        self.what, self.during = what, during
        self.proc: Optional[subprocess.Popen] = None
        self.t0 = 0.0
        self.log_path = os.path.join(run_dir, log_file)

    def start(self) -> None:
        if self.proc is not None:
            return
        env = {**os.environ, **CHILD_ALLOCATOR}
        self.t0 = time.time()
        try:
            with open(self.log_path, "w") as out:
                # Its own session: a Ctrl-C at the terminal reaches train.py only, which ends the child (close).
                self.proc = subprocess.Popen(self.argv, stdout=out, stderr=subprocess.STDOUT, env=env,
                                             start_new_session=True)
        except OSError as e:
            self.log(f"warning: compile ahead: could not start a second process for {self.what} ({e}); they "
                     f"compile when needed")
            return
        self.log(f"compile ahead: {self.what} compiling in a second process (pid {self.proc.pid}, "
                 f"log {self.log_path}) while {self.during}")

    def finish(self) -> dict:
        """Waits for the child (if started) -> {"wall_s", "waited_s", "status", "report"?}."""
        if self.proc is None:
            return {"status": "not started"}
        tw = time.time()
        if self.proc.poll() is None:
            self.log(f"compile ahead: waiting for the second process to finish {self.what} ...")
        rc = self.proc.wait()
        got = {"wall_s": round(time.time() - self.t0, 1), "waited_s": round(time.time() - tw, 1),
               "status": "done" if rc == 0 else f"exit code {rc}"}
        text = _read(self.log_path)
        report = _last_json_line(text)
        if report is not None:
            got["report"] = report
        if rc == 0:
            self.log(f"compile ahead: {self.what} ready after {got['wall_s']} s "
                     f"(waited {got['waited_s']} s for them)")
        else:
            last = _last_line(text)
            if last:
                got["last_line"] = last
            said = f", its last line: {last!r}" if last else ""
            if any(marker in text for marker in OUT_OF_MEMORY):  # its last line may be a later error it caused
                got["out_of_memory"] = True
                said += ("; it ran out of device memory: beside train.py, which holds JAX's preallocated pool "
                         "(75 % of the card unless XLA_PYTHON_CLIENT_MEM_FRACTION says otherwise), too little was left")
            self.log(f"warning: compile ahead: the second process ended with exit code {rc} (see "
                     f"{self.log_path}{said}); {self.what} compile when needed")
        return got

    def close(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


def _read(path: str) -> str:
    """The child's log ("" if it cannot be read)."""
    try:
        with open(path, errors="replace") as f:
            return f.read()
    except OSError:
        return ""


def _last_line(text: str, limit: int = 300) -> str:
    """The log's last non-blank line (the child's error, when it failed), cut to ``limit`` characters."""
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    return lines[-1][:limit] if lines else ""


# What the child's log says when it ran out of device memory (e.g. before Warp failed to load a module).
OUT_OF_MEMORY = ("CUDA_ERROR_OUT_OF_MEMORY", "RESOURCE_EXHAUSTED", "out of memory")


def _last_json_line(text: str) -> Optional[dict]:
    """The log's last line that starts with "{" as JSON (precompile's report), or None."""
    lines = [ln for ln in text.splitlines() if ln.startswith("{")]
    try:
        return json.loads(lines[-1]) if lines else None
    except ValueError:
        return None


__all__ = ["MODES", "LOG_FILE", "GATE_LOG_FILE", "command", "cache_root", "why_not", "CompileAhead"]
