"""Shared test set-up.

JAX compile time dominates this suite on CI's 2 CPU cores.  The product's compile cache
(``vags_jax.compile_cache``) points at a directory of this session: identical programs built by
different objects (e.g. train.py's first run and its --resume) compile once, and the worker
processes of one pytest-xdist run and the train.py subprocesses they start share it.  It starts
empty in every session (so CI times stay honest) unless VAGS_JAX_TEST_CACHE names a directory to
keep between sessions.
"""
import gc
import logging
import os
import tempfile

# The two settings of XLA's CPU compiler that the commands add on a CPU (``vags_jax.cpu_compile``:
# LLVM IR fusion emitters, about 30 % less compiling; LLVM level 1, the suite 17 % less CPU time,
# bench/RESULTS.md, "Suite time"), set for the whole suite whatever plugins are installed.  Set
# here, before JAX starts its backend, so that the xdist workers and the train.py / eval.py
# subprocesses inherit them (the suite's bit-for-bit checks compare runs under these settings); a
# flag that this jaxlib does not know (XLA aborts on it) is left out.
from vags_jax import cpu_compile  # noqa: E402  (imports JAX, whose backend reads XLA_FLAGS later)

_SUITE_FLAGS = (cpu_compile.FUSION, cpu_compile.OPT_LEVEL)
_PROBED = "VAGS_JAX_TEST_XLA_FLAGS_PROBED"

if not os.environ.get(_PROBED):
    _new = [f for f in _SUITE_FLAGS if f.split("=")[0] not in os.environ.get("XLA_FLAGS", "")]  # not the caller's
    _base = os.environ.get("XLA_FLAGS", "")
    _ok = cpu_compile.accepted(_new, _base, None) if _new else []  # tried in a child process
    if _ok:
        os.environ["XLA_FLAGS"] = " ".join([_base] + _ok).strip()
    os.environ[_PROBED] = "1"

# Python's garbage collector ran 7 % of the CPU time of compiling the stage-1 reset (perf): tracing
# allocates many short-lived objects.  Young collections every 50,000 allocations instead of 700
# (full ones as often relative to them): tests/sim/test_simulator.py took 70-71 s of user CPU
# time against 75 s, with the same peak memory (1.2 GB).  The suite's processes only; train.py
# and eval.py keep Python's default.
gc.set_threshold(50000, 50, 10)

import jax  # noqa: E402
import pytest  # noqa: E402

from vags_jax import compile_cache  # noqa: E402

_run_id = os.environ.get("PYTEST_XDIST_TESTRUNUID")  # the same in every worker of one run
_cache = (os.environ.get("VAGS_JAX_TEST_CACHE")
          or (os.path.join(tempfile.gettempdir(), f"vags_jax_jit_{_run_id}") if _run_id
              else tempfile.mkdtemp(prefix="vags_jax_jit_")))
os.environ[compile_cache.ENV] = _cache  # train.py / eval.py subprocesses of the suite use it too
compile_cache.enable()


class _CompileLog(logging.Handler):
    """With VAGS_JAX_TEST_COMPILE_LOG=FILE: one line per JAX trace / lowering / XLA compile and
    per persistent-cache hit or miss (with its key), "test<TAB>what", appended to FILE (by every
    worker) -- to see which tests compile what, and which compile the same program."""

    def __init__(self, path):
        super().__init__()
        self.path = path

    def emit(self, record):
        msg = record.getMessage()
        if msg.startswith(("Finished", "Persistent compilation cache", "PERSISTENT COMPILATION CACHE")):
            with open(self.path, "a") as f:
                f.write(f"{os.environ.get('PYTEST_CURRENT_TEST', '-')}\t{msg}\n")


if os.environ.get("VAGS_JAX_TEST_COMPILE_LOG"):
    jax.config.update("jax_log_compiles", True)
    logging.getLogger("jax").addHandler(_CompileLog(os.environ["VAGS_JAX_TEST_COMPILE_LOG"]))
    logging.getLogger("jax._src.compiler").setLevel(logging.DEBUG)  # cache misses are logged at DEBUG


# The costliest test files, longest first (seconds on 2 cores: tests/README.md).  With
# `--no-loadscope-reorder` (pyproject.toml) pytest-xdist hands out files in collection order, so
# these start at once and the two workers end together (longest first); the rest keep their order.
# The medium files after them, so that the last files handed out are short ones.  Files that load
# a program another file compiles stay out (benchmark/test_compare.py after test_evaluate.py,
# predict/test_predict.py after policies/test_viewpoint.py), so that they run after it.
LONGEST_FIRST = ("stages/test_stages.py", "stages/test_data_parallel.py", "stages/test_vpg_stage.py",
                 "sim/test_warp_parity.py", "sim/test_simulator.py", "ggcnn/test_ggcnn_data.py",
                 "sim/test_clutter.py", "benchmark/test_evaluate.py", "policies/test_viewpoint.py",
                 "sim/test_push.py", "env/test_env.py", "test_bad_inputs.py", "test_densenet_speed_bench.py",
                 "stages/test_actor_bootstrap.py")


def pytest_collection_modifyitems(config, items):
    here = os.path.dirname(os.path.abspath(__file__))
    rank = {name: i for i, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(os.path.relpath(str(item.path), here).replace(os.sep, "/"),
                                         len(LONGEST_FIRST)))


# The `tiny` preset, shrunk further for tests: 2 worlds, 1-2 objects, small replay.
TINY_TEST_OVERRIDES = {
    "stage1.n_worlds": 2,
    "stage1.max_objects": 2,
    "stage1.learning_starts": 2,
    "dqn.batch_size": 4,
    "replay.capacity": 64,
}


# Pyramidal friction cones, as train.py --set strings, for the data-parallel checks and the
# viewpoint and predict tests' scenes of placed blocks (the 2-device chunk compiles about 20 %
# faster; the 1- and 2-device grasp steps then agree to 1.4e-5 in joint positions, against
# 3.4e-4 with elliptic cones).  With boxes too they drifted 35 mm in heights.
PYRAMIDAL = ["sim.cone=pyramidal"]

# Physics whose programs compile about a third faster (boxes only, pyramidal friction cones), for
# tests whose checks hold whatever the contacts are (the pipeline's and VPG's stages, GG-CNN's
# dataset).  The physics tests keep the presets' physics (bench/RESULTS.md, "Test suite").
FAST_PHYSICS = ['scene.shapes=["box","box","box"]', *PYRAMIDAL]


@pytest.fixture(scope="session")
def tiny_cfg():
    from vags_jax import config as C

    return C.replace(C.tiny(), **TINY_TEST_OVERRIDES)


@pytest.fixture(scope="session")
def fast_cfg(tiny_cfg):
    """``tiny_cfg`` on FAST_PHYSICS, for tests that check mechanics, not contacts (the benchmark's
    tiny run).  Its reset of 2 worlds is the one program the pipeline (``stages/test_stages.py``)
    and VPG's stage (``stages/test_vpg_stage.py``) compile at the start of the suite, so these
    tests load it from the session's compile cache instead of compiling the presets' reset again
    beside ``sim/test_clutter.py`` (which keeps capsules and elliptic cones)."""
    from vags_jax import config as C

    return C.replace(tiny_cfg, **C.parse_overrides(FAST_PHYSICS))


@pytest.fixture(scope="session")
def programs():
    """The environments, stages and GG-CNN data makers built by train.py in this session
    (``driver.Programs``): pass it to ``train.main(argv, programs)`` to compile each once."""
    from vags_jax.stages import driver

    return driver.Programs()

