"""Shared helpers for the bench scripts (run as ``python bench/<script>.py``): timing, named
config variants, result rows."""
from __future__ import annotations

import json
import time

import jax
import jax.numpy as jnp
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


def matmul_peak(n: int) -> float:
    """FLOP/s of an (n, n) x (n, n) bf16 matrix multiply with float32 accumulation: the peak an
    MFU is taken against (median of 20 calls)."""
    a = jax.random.normal(jax.random.PRNGKey(0), (n, n), jnp.bfloat16)
    f = jax.jit(lambda x, y: jnp.matmul(x, y, preferred_element_type=jnp.float32))
    return 2 * n ** 3 / timed(f, a, a, repeats=20)[0]


def parse_variant(spec: str) -> tuple[str, list[str]]:
    """``"name:a.b=1;c.d=2"`` -> ("name", ["a.b=1", "c.d=2"]) (overrides as for ``--set``)."""
    name, _, ov = spec.partition(":")
    return name, [o for o in ov.split(";") if o]


def emit_row(row: dict, out: str | None) -> None:
    """Print a result row as JSON and, with ``out``, append it to that JSON-lines file."""
    print(json.dumps(row), flush=True)
    if out:
        with open(out, "a") as f:
            f.write(json.dumps(row) + "\n")
