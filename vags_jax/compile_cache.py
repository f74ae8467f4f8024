"""One on-disk cache for compiled programs, shared by train.py, eval.py, predict and gate_measure.

It holds JAX's persistent compilation cache (XLA executables, ``<dir>/jax``) and Warp's kernel
cache (``<dir>/warp``, used by MJX impl "warp").  With it warm, a resumed run, the next stage's
shared programs and a second evaluation load what an earlier process compiled instead of
compiling it again.  Where it lives, in order: ``--cache-dir``; ``$VAGS_JAX_CACHE_DIR``;
``$XDG_CACHE_HOME/vags_jax/compiled`` (``~/.cache/vags_jax/compiled``).  ``--cache-dir off`` (or
``VAGS_JAX_CACHE_DIR=off``) turns it off.  A cache directory set by the caller through JAX's own
config (``JAX_COMPILATION_CACHE_DIR``, or ``jax.config`` in a test session) is kept unless
``--cache-dir`` names another.  Deleting the directory is always safe: it only costs compiling.
"""
from __future__ import annotations

import os
from typing import Optional

import jax

OFF = ("off", "none", "0")
ENV = "VAGS_JAX_CACHE_DIR"


def default_dir() -> str:
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "vags_jax", "compiled")


def resolve(flag: Optional[str]) -> Optional[str]:
    """The cache directory to use (absolute), or None when it is off.  ``flag``: --cache-dir."""
    value = flag if flag is not None else os.environ.get(ENV)
    if value is not None and value.strip().lower() in OFF:
        return None
    return os.path.abspath(os.path.expanduser(value)) if value else default_dir()


def enable(flag: Optional[str] = None) -> Optional[str]:
    """Points JAX's persistent compilation cache and Warp's kernel cache into the cache
    directory (see the module docstring); returns the JAX cache directory in use, or None.

    Must run before the first compile of the process: JAX reads the setting once.  Every
    program is cached whatever its compile time, so a process that builds its programs as an
    earlier one did loads them all (a resume can still miss: bench/RESULTS.md, "Compile cache").
    """
    path = resolve(flag)
    caller_dir = jax.config.jax_compilation_cache_dir
    if caller_dir and flag is None:  # the caller chose JAX's cache; keep theirs
        return caller_dir
    if path is None:
        return None
    jax_dir = os.path.join(path, "jax")
    try:
        os.makedirs(jax_dir, exist_ok=True)
    except OSError as e:
        raise ValueError(f"--cache-dir {path!r}: cannot create it ({e.strerror}); give a writable directory "
                         f"or 'off'") from None
    if not os.access(jax_dir, os.W_OK | os.X_OK):
        raise ValueError(f"--cache-dir {path!r}: not writable; give a writable directory or 'off'")
    jax.config.update("jax_compilation_cache_dir", jax_dir)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
    _point_warp(os.path.join(path, "warp"))
    return jax_dir


def _point_warp(warp_dir: str) -> None:
    """Warp's kernel cache into ``warp_dir`` unless WARP_CACHE_PATH chose one (read at Warp's init,
    which comes later: the first MJX impl "warp" model)."""
    if os.environ.get("WARP_CACHE_PATH"):
        return
    try:
        import warp  # optional: MJX impl "warp" (the gpu extra)
    except ImportError:
        return
    warp.config.kernel_cache_dir = warp_dir


COMPILE_EVENTS = "/jax/core/compile/"  # tracing, lowering and XLA compiling of a jitted call
BACKEND_EVENT = "/jax/core/compile/backend_compile_duration"  # an XLA compile, or a load from this cache
CACHE_HIT_EVENT = "/jax/compilation_cache/cache_hits"


class CompileClock:
    """What JAX did to compile while this context was open: ``seconds`` (tracing, lowering and
    XLA compiling or loading), ``compiled`` (XLA compiles) and ``loaded`` (executables read from
    the persistent cache instead).  Counts every thread of the process."""

    def __init__(self):
        self.seconds, self.backend, self.loaded = 0.0, 0, 0
        self._open = False

    @property
    def compiled(self) -> int:
        return self.backend - self.loaded

    def _duration(self, event: str, duration: float, **_) -> None:
        if event.startswith(COMPILE_EVENTS):
            self.seconds += duration
        if event == BACKEND_EVENT:
            self.backend += 1

    def _event(self, event: str, **_) -> None:
        if event == CACHE_HIT_EVENT:
            self.loaded += 1

    def as_dict(self) -> dict:
        return {"seconds": round(self.seconds, 2), "compiled": self.compiled, "loaded": self.loaded}

    def __enter__(self) -> "CompileClock":
        jax.monitoring.register_event_duration_secs_listener(self._duration)
        jax.monitoring.register_event_listener(self._event)
        self._open = True
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Stops counting (once; later calls do nothing)."""
        if self._open:
            jax.monitoring.unregister_event_duration_listener(self._duration)
            jax.monitoring.unregister_event_listener(self._event)
            self._open = False
