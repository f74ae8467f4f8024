"""Cholesky factorisations and triangular solves on the CPU by XLA's own algorithms, not jaxlib's
LAPACK kernels.

MJX (impl "jax") factorises each world's inertia matrix twice in a step: ``factor_m`` in the
forward pass, and the Euler integrator's solve with joint damping, both from the same M, so XLA
runs the two at the same time.  jaxlib 0.10's LAPACK kernels on the CPU (``lapack_spotrf_ffi``
and ``lapack_strsm_ffi`` among them) split a large batch over XLA's intra-op thread pool and wait
for the pieces.  With a pool of two threads (a 2-core machine, such as CI's) both threads then
wait for pieces that no thread is free to run, and the program never ends: ``eval.py --run
runs/tiny`` (150 worlds) hung there with every thread asleep, both pool threads inside the
Cholesky kernel (bench/RESULTS.md, "The CPU physics deadlock").  jaxlib 0.11.2 is reported to
build those kernels without the parallel path; this package's CPU users may have an older one.

``use_xla_linalg_on_cpu()`` lowers ``lax.linalg.cholesky`` and ``lax.linalg.triangular_solve``
(what ``jax.scipy.linalg.cho_factor`` / ``cho_solve`` use, the only linear algebra of MJX's step)
on the CPU to the ``cholesky`` and ``triangular_solve`` HLO ops, which XLA's CPU compiler expands
into loops inside the program, so nothing waits on the pool.  The results differ from LAPACK's
in their last bits only.  GPUs keep their own lowerings (cuSOLVER), and impl "warp" uses neither.
It is applied when ``vags_jax.sim`` is imported, before any physics program is lowered, and holds
for the whole process.  It uses JAX's internal lowering registry: if a JAX release moves it,
nothing is changed and ``applied()`` says so.
"""
from __future__ import annotations

_applied = False


def use_xla_linalg_on_cpu() -> bool:
    """Registers the HLO ops as the CPU lowerings of ``cholesky_p`` and ``triangular_solve_p``
    (idempotent).  Returns whether they are in place: False when this JAX lacks the internals."""
    global _applied
    if _applied:
        return True
    try:
        from jax._src.interpreters import mlir
        from jax._src.lax import linalg
        pairs = ((linalg.cholesky_p, linalg._cholesky_lowering),
                 (linalg.triangular_solve_p, linalg._triangular_solve_lowering))
    except (ImportError, AttributeError):
        return False
    for primitive, lowering in pairs:
        mlir.register_lowering(primitive, lowering, platform="cpu")
    _applied = True
    return True


def applied() -> bool:
    """Whether the CPU's Cholesky factorisations and triangular solves lower to XLA's algorithms
    in this process."""
    return _applied


__all__ = ["use_xla_linalg_on_cpu", "applied"]
