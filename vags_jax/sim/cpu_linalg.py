"""Large batches of Cholesky factorisations and triangular solves on the CPU by XLA's own
algorithms, not jaxlib's LAPACK kernels.

MJX (impl "jax") factorises each world's inertia matrix twice in a step: ``factor_m`` in the
forward pass, and the Euler integrator's solve with joint damping, both from the same M, so XLA
runs the two at the same time.  jaxlib 0.10's LAPACK kernels on the CPU (``lapack_spotrf_ffi``
and ``lapack_strsm_ffi`` among them) split a large batch over XLA's intra-op thread pool and wait
for the pieces.  With a pool of two threads (a 2-core machine, such as CI's) both threads then
wait for pieces that no thread is free to run, and the program never ends: ``eval.py --run
runs/tiny`` (150 worlds) hung there with every thread asleep, both pool threads inside the
Cholesky kernel, and ``bench/cpu_linalg_speed.py --lowering lapack`` hangs from 64 worlds
(bench/RESULTS.md, "The CPU physics deadlock").  jaxlib 0.11.2 is reported to build those
kernels without the parallel path; this package's CPU users may have an older one.

``use_xla_linalg_on_cpu()`` lowers ``lax.linalg.cholesky`` and ``lax.linalg.triangular_solve``
(what ``jax.scipy.linalg.cho_factor`` / ``cho_solve`` use, the only linear algebra of MJX's step)
on the CPU, for batches of more than ``LAPACK_MAX_BATCH`` matrices, to the ``cholesky`` and
``triangular_solve`` HLO ops, which XLA's CPU compiler expands into loops inside the program, so
nothing waits on the pool.  Smaller batches keep LAPACK's kernels: on 2 cores they never hung up
to 32 worlds (24 x 24 matrices) and 16 (84 x 84), and MJX's step runs 2.3-2.5x faster with them at 8
worlds (the tests' sizes).  The results differ in their last bits only.  GPUs keep their own
lowerings (cuSOLVER), and impl "warp" uses neither.  It is applied when ``vags_jax.sim`` is
imported, before any physics program is lowered, and holds for the whole process.  It uses JAX's
internal lowering registry: if a JAX release moves it, nothing is changed and ``applied()`` says so.
"""
from __future__ import annotations

import math

# Batches of at most this many matrices keep jaxlib's LAPACK kernels (see the module docstring).
LAPACK_MAX_BATCH = 16
_max_batch = None  # the max_batch of the lowerings in place; None: JAX's own


def _by_batch(lapack_rule, xla_rule, max_batch: int):
    """A lowering rule: ``lapack_rule`` for operands of at most ``max_batch`` matrices (the
    batch dimensions of the first operand), ``xla_rule`` for more."""
    def rule(ctx, *args, **params):
        batch = math.prod(ctx.avals_in[0].shape[:-2])
        return (lapack_rule if batch <= max_batch else xla_rule)(ctx, *args, **params)
    return rule


def use_xla_linalg_on_cpu(max_batch: int = LAPACK_MAX_BATCH) -> bool:
    """Registers CPU lowerings of ``cholesky_p`` and ``triangular_solve_p`` that use the HLO ops
    for batches over ``max_batch`` (0: always) and LAPACK's kernels up to it; a later call
    replaces them (programs already lowered keep theirs).  Returns whether they are in place:
    False when this JAX lacks the internals."""
    global _max_batch
    if _max_batch == max_batch:
        return True
    try:
        from jax._src.interpreters import mlir
        from jax._src.lax import linalg
        rules = ((linalg.cholesky_p, linalg._cholesky_cpu_lowering, linalg._cholesky_lowering),
                 (linalg.triangular_solve_p, linalg._triangular_solve_cpu_lower, linalg._triangular_solve_lowering))
    except (ImportError, AttributeError):
        return False
    for primitive, lapack_rule, xla_rule in rules:
        mlir.register_lowering(primitive, _by_batch(lapack_rule, xla_rule, max_batch), platform="cpu")
    _max_batch = max_batch
    return True


def applied() -> bool:
    """Whether large batches of Cholesky factorisations and triangular solves lower to XLA's
    algorithms on the CPU in this process."""
    return _max_batch is not None


__all__ = ["LAPACK_MAX_BATCH", "use_xla_linalg_on_cpu", "applied"]
