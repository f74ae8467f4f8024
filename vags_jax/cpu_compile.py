"""Faster compiles on a CPU: two settings of XLA's CPU compiler that the commands (train.py,
eval.py, predict, gate_measure, ...) add to ``XLA_FLAGS`` before JAX starts its backend, where JAX
can only run on the CPU (no GPU plugin installed, or ``JAX_PLATFORMS=cpu``).

On a CPU most of a small run is XLA compiling its programs. The settings:

* ``--xla_cpu_use_fusion_emitters=false``: XLA's LLVM IR fusion emitters instead of its MLIR ones;
* ``--xla_backend_optimization_level=1``: LLVM's level 1 instead of 2 (on a GPU this option would
  set the level of XLA's GPU kernels too, one reason a GPU machine gets neither).

On a 2-core CPU the README's ``train.py --config tiny`` took 278.9 s with both, 286.9 s with the
first alone and 323.5 s with neither, the stages running at the same speed; a 12-round
``eval.py`` look 104.1 s against 130.1 s (bench/RESULTS.md, "Faster compiles on a CPU"). Results
can differ from XLA's defaults in the last bits, and a simulated pile then from its next steps on.

A flag that the installed jaxlib does not know would abort the process, so the flags are tried
once per jaxlib version in a child process (about 2 s) and the answer kept beside the compile
cache (``xla_cpu_flags.json``). A flag that the caller's ``XLA_FLAGS`` sets already is left as
set; ``VAGS_JAX_CPU_FLAGS=off`` adds none.
"""
from __future__ import annotations

import importlib.metadata
import json
import os
import pkgutil
import subprocess
import sys
from typing import Callable, Optional

FUSION = "--xla_cpu_use_fusion_emitters=false"
OPT_LEVEL = "--xla_backend_optimization_level=1"
ENV = "VAGS_JAX_CPU_FLAGS"
RECORD = "xla_cpu_flags.json"


def _name(flag: str) -> str:
    return flag.split("=")[0]


def gpu_possible(environ=None) -> bool:
    """Whether JAX may start a GPU backend: a JAX plugin is installed (e.g. jax-cuda12-plugin)
    and ``JAX_PLATFORMS`` does not restrict it to the CPU."""
    environ = os.environ if environ is None else environ
    platforms = environ.get("JAX_PLATFORMS", "").strip().lower()
    if platforms:
        return any(p.strip() not in ("", "cpu") for p in platforms.split(","))
    if importlib.metadata.entry_points(group="jax_plugins"):
        return True
    try:  # plugins found as modules of the jax_plugins namespace package (jax-cuda12-plugin's way)
        import jax_plugins
    except ImportError:
        return False
    return any(True for _ in pkgutil.iter_modules(jax_plugins.__path__))


def wanted(environ=None, gpu: Optional[bool] = None) -> list[str]:
    """The flags to add, given the environment (``gpu``: whether JAX may start a GPU backend,
    default ``gpu_possible``): none with ``VAGS_JAX_CPU_FLAGS=off`` or where a GPU may run;
    neither where ``XLA_FLAGS`` names it already."""
    environ = os.environ if environ is None else environ
    if environ.get(ENV, "").strip().lower() in ("off", "0", "none", "false"):
        return []
    if gpu_possible(environ) if gpu is None else gpu:
        return []
    present = environ.get("XLA_FLAGS", "")
    return [f for f in (FUSION, OPT_LEVEL) if _name(f) not in present]


def xla_accepts(flags: str) -> bool:
    """Whether a JAX process starts its CPU backend with ``XLA_FLAGS=flags`` (XLA aborts on a
    flag it does not know)."""
    env = {**os.environ, "XLA_FLAGS": flags, "JAX_PLATFORMS": "cpu", ENV: "off"}
    try:
        return subprocess.run([sys.executable, "-c", "import jax; jax.devices('cpu')"], env=env,
                              capture_output=True, timeout=300).returncode == 0
    except (OSError, subprocess.SubprocessError):
        return False


def accepted(flags: list[str], base: str, record_dir: Optional[str],
             probe: Callable[[str], bool] = xla_accepts) -> list[str]:
    """The flags of ``flags`` that this jaxlib accepts beside ``base`` (the caller's XLA_FLAGS),
    from ``record_dir``/xla_cpu_flags.json where an earlier process tried them with this jaxlib,
    else tried now (all at once, then one by one) and recorded there."""
    try:
        version = importlib.metadata.version("jaxlib")
    except importlib.metadata.PackageNotFoundError:
        version = "unknown"
    path = os.path.join(record_dir, RECORD) if record_dir else None
    known = {}
    if path and os.path.exists(path):
        try:
            with open(path) as f:
                known = json.load(f)
        except (OSError, ValueError):
            known = {}
    key = f"jaxlib {version}"
    verdicts = dict(known.get(key, {}))
    untried = [f for f in flags if f not in verdicts]
    if untried:
        if probe(" ".join([base, *untried]).strip()):
            verdicts.update({f: True for f in untried})
        else:
            for f in untried:
                verdicts[f] = probe(" ".join([base, f]).strip())
        if path:
            try:
                os.makedirs(record_dir, exist_ok=True)
                tmp = f"{path}.{os.getpid()}"
                with open(tmp, "w") as f:
                    json.dump({**known, key: verdicts}, f, indent=1)
                os.replace(tmp, path)
            except OSError:
                pass  # only a record: the next process tries again
    return [f for f in flags if verdicts.get(f)]


def add_flags(record_dir: Optional[str], environ=None, probe: Callable[[str], bool] = xla_accepts) -> list[str]:
    """Adds the flags (``wanted``, those this jaxlib ``accepted``) to ``environ["XLA_FLAGS"]``
    and returns them; none once JAX's backend has started (it read XLA_FLAGS then)."""
    environ = os.environ if environ is None else environ
    if environ is os.environ and "jax" in sys.modules:
        from jax._src import xla_bridge
        if xla_bridge.backends_are_initialized():
            return []
    flags = wanted(environ)
    if not flags:
        return []
    base = environ.get("XLA_FLAGS", "")
    flags = accepted(flags, base, record_dir, probe)
    if flags:
        environ["XLA_FLAGS"] = " ".join([base, *flags]).strip()
    return flags
