"""The environment: B simulated worlds observed as heightmaps and grasped in heightmap coordinates.

``environment.VagsEnv`` builds scene, simulator and renderer once; its state is an ``EnvState``
(physics + the latest global-view heightmaps + round counters); an ``Attempt`` is one planned
grasp per world (direct, or after a viewpoint move).  ``observation`` renders the worlds (RGB-D
image, sensor model, heightmaps); ``VagsEnv`` is built on it.
"""
from vags_jax.env.environment import (Attempt, CameraImage, EnvState, VagsEnv, grasp_pose, select_attempt,
                                      where_worlds)

__all__ = ["Attempt", "CameraImage", "EnvState", "VagsEnv", "grasp_pose", "select_attempt", "where_worlds"]
