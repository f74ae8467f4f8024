"""Shared timing helper for the bench scripts (run as ``python bench/<script>.py``)."""
from __future__ import annotations

import time

import jax
import numpy as np


def timed(fn, *args, repeats: int = 3):
    """Call fn(*args) once to compile and warm up, then ``repeats`` times.

    Returns (median seconds of the timed calls, the last output); every call is waited for
    with ``jax.block_until_ready``.
    """
    out = jax.block_until_ready(fn(*args))
    ts = []
    for _ in range(repeats):
        t = time.perf_counter()
        out = jax.block_until_ready(fn(*args))
        ts.append(time.perf_counter() - t)
    return float(np.median(ts)), out
