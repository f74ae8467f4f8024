"""Physics: the MuJoCo scene and batched MJX simulation of B worlds.

* ``scene``: the ``MjSpec`` of table, floating gripper and object pool (``build_scene``).
* ``simulator``: ``Simulator``, the scene reset (drop + settle) and the top-down grasp primitive
  over a ``SimState`` of B worlds (impl "jax" or "warp"), assembled from one module per part:
  ``state``, ``buffers``, ``world_model``, ``stepping``, ``piles``, ``grasp``.
"""
