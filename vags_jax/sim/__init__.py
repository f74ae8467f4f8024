"""Physics: the MuJoCo scene and batched MJX simulation of B worlds.

* ``scene``: the ``MjSpec`` of table, floating gripper and object pool (``build_scene``).
* ``simulator``: ``Simulator``, the scene reset (drop + settle) and the top-down grasp primitive
  over a ``SimState`` of B worlds (impl "jax" or "warp"), assembled from one module per part:
  ``state``, ``buffers``, ``world_model``, ``stepping``, ``piles``, ``grasp``.
* ``cpu_linalg``: large batches of MJX's Cholesky factorisations and triangular solves on the
  CPU by XLA's algorithms, not jaxlib's LAPACK kernels, whose batch splitting deadlocks on a
  2-core machine (applied on import).
"""
from .cpu_linalg import use_xla_linalg_on_cpu

use_xla_linalg_on_cpu()
