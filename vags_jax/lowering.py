"""Lowering that does not depend on what the process traced before (jax-ml/jax#40312).

JAX lowers every nested ``jit`` (``jnp.remainder``, ``jnp.take``'s ``_take``, ``jnp.where``, ...)
to one private function per distinct jaxpr *object* (``pjit._pjit_lowering`` dedups by object
identity).  Those objects come from JAX's LRU caches of traced and transformed jaxprs (2048
entries each), which are layered: a hit on an outer entry (e.g. the vmapped ``_take``) returns
the inner objects it was built with, while an evicted inner entry (the vmapped ``remainder``) is
rebuilt as a new object.  A program traced after others thus mixes old and new objects of one
jaxpr and lowers to other text (more ``@remainder_N`` functions): the persistent compile cache,
keyed on that text, misses for every ``VagsEnv`` of a process but the first.

``pin_jaxpr_caches`` puts an unbounded cache in front of each such JAX cache: one object per key
for as long as the key's jaxpr lives (the caches hold their first argument weakly), so equal
nested computations lower to one function whatever was traced before.  The programs are the
same computations (XLA inlines the calls); only the text, and so the cache key, is stable.
"""
from __future__ import annotations

from jax._src import pjit, util
from jax._src.interpreters import ad, batching
from jax._src.interpreters import partial_eval as pe

# JAX's caches whose results are nested-jit jaxprs (module, name): tracing, vmap, DCE, AD.
_JAXPR_CACHES = (
    (pjit, "_infer_params_cached"),
    (batching, "_batch_jaxpr2"),
    (pjit, "_dce_jaxpr_pjit"),
    (pe, "_dce_jaxpr"),
    (ad, "_jvp_jaxpr"),
    (pe, "_partial_eval_jaxpr_nounits"),
    (pe, "_partial_eval_jaxpr_custom_cached"),
    (pjit, "_transpose_jaxpr_fancy"),
)
_PINNED = "_vags_jax_pinned"  # marks a cache this module installed


def pin_jaxpr_caches() -> list[str]:
    """Installs the unbounded caches (once per process); returns the names of those pinned.  A
    name missing in this JAX version is skipped (``tests/env/test_lowering.py`` then fails)."""
    done = []
    for module, name in _JAXPR_CACHES:
        cached = getattr(module, name, None)
        if cached is None:
            continue
        if not getattr(module, _PINNED + name, False):
            setattr(module, name, util.weakref_lru_cache(cached, maxsize=None))
            setattr(module, _PINNED + name, True)
        done.append(f"{module.__name__}.{name}")
    return done
