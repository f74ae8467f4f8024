"""Data parallelism over a 1-D device mesh (axis "data"): ``collectives`` (psum / pmean ...
that are the identity on one device, used by the per-device training code) and ``mesh``
(device count, mesh, ``jax.distributed``).  The data-parallel stage itself is
``vags_jax.stages.data_parallel``."""
