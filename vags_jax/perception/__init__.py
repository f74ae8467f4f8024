"""What the eye-in-hand camera sees and how it becomes heightmaps.

* ``camera``: pinhole geometry, poses (global, viewpoint), heightmap cell <-> world.
* ``render``: batched RGB-D rendering (pure-JAX ray caster or MJX's Warp renderer) and the
  structured-light sensor model (noise, holes).
* ``heightmap``: depth -> (H, W) colour and height heightmaps; checks of a real RGB-D frame.
* ``view_fusion``: a close view projected into the global heightmaps.
* ``topdown``: ground-truth top-down maps (a headroom oracle for benchmarks).
"""
