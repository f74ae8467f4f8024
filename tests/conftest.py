"""Shared test set-up.

JAX compile time dominates this suite on CI's 2 CPU cores.  A persistent compilation cache for
the session lets identical programs built by different objects (e.g. train.py's first run and its
--resume) compile once.  It starts empty in every session (so CI times stay honest) unless
VAGS_JAX_TEST_CACHE names a directory to keep between sessions.
"""
import os
import tempfile

import jax
import pytest

_cache = os.environ.get("VAGS_JAX_TEST_CACHE") or tempfile.mkdtemp(prefix="vags_jax_jit_")
jax.config.update("jax_compilation_cache_dir", _cache)
jax.config.update("jax_persistent_cache_min_compile_time_secs", 1.0)


# The `tiny` preset, shrunk further for tests: 2 worlds, 1-2 objects, small replay.
TINY_TEST_OVERRIDES = {
    "stage1.n_worlds": 2,
    "stage1.max_objects": 2,
    "stage1.learning_starts": 2,
    "dqn.batch_size": 4,
    "replay.capacity": 64,
}


@pytest.fixture(scope="session")
def tiny_cfg():
    from vags_jax import config as C

    return C.replace(C.tiny(), **TINY_TEST_OVERRIDES)


@pytest.fixture(scope="session")
def programs():
    """The environments, stages and GG-CNN data makers built by train.py in this session
    (``driver.Programs``): pass it to ``train.main(argv, programs)`` to compile each once."""
    from vags_jax.stages import driver

    return driver.Programs()
