"""Command-line plumbing shared by train.py and eval.py: one-line errors, range-checked flags.

Every bad flag ends the program with exit code 2 and ONE line on stderr
(``train.py: error: argument --chunk: must be an int >= 1, got '-5'``), before anything is
compiled or written.
"""
from __future__ import annotations

import argparse
import logging
import math
import os
import sys
import tempfile
from typing import Optional

from absl import logging as absl_logging  # comes with orbax-checkpoint

from vags_jax import compile_cache, cpu_compile


class ArgumentParser(argparse.ArgumentParser):
    """argparse, but an error is one line (no usage block): ``prog: error: ...``, exit code 2."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


def int_in(lo: int, hi: Optional[int] = None):
    """argparse type: an int in [lo, hi]."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be an int, got {text!r}") from None
        if value < lo or (hi is not None and value > hi):
            raise argparse.ArgumentTypeError(
                f"must be an int >= {lo}" + (f" and <= {hi:,}" if hi is not None else "") + f", got {text!r}")
        return value

    parse.__name__ = "int"
    return parse


def devices(text: str):
    """argparse type of --devices: a positive int, or "all"."""
    if text == "all":
        return text
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a positive int or 'all', got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive int or 'all', got {text!r}")
    return value


devices.__name__ = "devices"


def positive_float(hi: Optional[float] = None):
    """argparse type: a finite float in (0, hi]."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be a number, got {text!r}") from None
        if not math.isfinite(value) or value <= 0 or (hi is not None and value > hi):
            raise argparse.ArgumentTypeError(
                "must be a finite number > 0" + (f" and <= {hi:g}" if hi is not None else "") + f", got {text!r}")
        return value

    parse.__name__ = "float"
    return parse


def fail(prog: str, message) -> int:
    """Prints ``prog: error: message`` (one line) to stderr; returns exit code 2."""
    text = " ".join(str(message).split("\n"))
    print(f"{prog}: error: {text}", file=sys.stderr)
    return 2


def out_of_memory(e: BaseException) -> Optional[str]:
    """XLA's first line without its status (what it tried to allocate) when ``e`` says the
    accelerator ran out of memory (RESOURCE_EXHAUSTED), else None."""
    if "RESOURCE_EXHAUSTED" not in str(e):
        return None
    return first_line(e, 160).replace("RESOURCE_EXHAUSTED: ", "")


def drop_failed_device_work() -> None:
    """Call after catching a computation that failed on the device (out of memory).  JAX keeps the
    runtime tokens of programs with side effects (MJX's Warp renderer and BVH are FFI calls marked
    so), and a failed token raises again from JAX's exit handlers: two tracebacks after our one-line
    error (seen on an H200 when a Warp-renderer training ran out of memory).
    Waits for the tokens once here and forgets the failed ones."""
    import jax

    try:
        jax.effects_barrier()
    except Exception:  # the failure already reported by the caller
        from jax._src import dispatch  # no public API drops a failed token

        tokens = getattr(dispatch, "runtime_tokens", None)
        if tokens is not None and hasattr(tokens, "clear"):
            tokens.clear()


def first_line(e, limit: int = 200) -> str:
    lines = str(e).strip().splitlines()
    text = lines[0] if lines else type(e).__name__
    return text if len(text) <= limit else text[:limit] + "..."


def check_writable_file(path: str, flag: str) -> None:
    """A file path we will write: not a directory, its directory creatable and writable."""
    if not path:
        raise ValueError(f"{flag} must not be empty")
    if os.path.isdir(path):
        raise ValueError(f"{flag} {path!r} is a directory; give a file name, e.g. {os.path.join(path, 'report.json')}")
    check_parent_writable(path, flag)


def check_parent_writable(path: str, flag: str) -> None:
    parent = os.path.dirname(os.path.abspath(path))
    while not os.path.exists(parent):  # the nearest existing ancestor must be a writable directory
        parent = os.path.dirname(parent)
    if not os.path.isdir(parent):
        raise ValueError(f"{flag} {path!r}: {parent!r} is a file, not a directory")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ValueError(f"{flag} {path!r}: no permission to write in {parent!r}")
    try:  # proven by writing: os.access says yes to root on read-only mounts and in /proc
        with tempfile.NamedTemporaryFile(dir=parent, prefix=".vags_jax_write_check_"):
            pass
    except OSError as e:
        raise ValueError(f"{flag} {path!r}: cannot write in {parent!r} ({first_line(e)})") from None


def quiet_third_party(verbose: bool) -> None:
    """Silences third-party log noise (Warp's kernel-loading lines, absl / orbax INFO chatter)
    unless ``verbose``; our own messages and every warning or error still show."""
    level = logging.INFO if verbose else logging.WARNING
    for name in ("absl", "orbax", "jax._src.xla_bridge"):
        logging.getLogger(name).setLevel(level)
    absl_logging.set_verbosity(absl_logging.INFO if verbose else absl_logging.WARNING)
    try:
        import warp
        warp.config.quiet = not verbose
    except ImportError:  # warp-lang is optional (impl "warp")
        pass


def add_cache_dir(p: argparse.ArgumentParser) -> None:
    p.add_argument("--cache-dir", default=None, metavar="DIR",
                   help="compiled programs (JAX's and Warp's) are cached here and reused by later runs "
                        f"(default ${compile_cache.ENV}, else ~/.cache/vags_jax/compiled; 'off' turns it off)")


def use_compile_cache(prog: str, flag: Optional[str]) -> Optional[int]:
    """Turns on the compile cache (``compile_cache.enable``) and XLA's faster CPU compiles
    (``cpu_compile.add_flags``) -> None, or exit code 2 after one line saying what to fix when
    the directory is unusable."""
    try:
        compile_cache.enable(flag)
    except ValueError as e:
        return fail(prog, e)
    cpu_compile.add_flags(compile_cache.resolve(flag))  # before JAX starts its backend
    return None
