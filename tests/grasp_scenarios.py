"""Scripted grasp scenarios shared by the simulator tests (impl "jax" and the warp parity test).

Scene: shapes ("cube", "cuboid_long"), one copy each -> pool indices CUBE = 0, LONG = 1.
"""
import jax.numpy as jnp
import numpy as np

from vags_jax.config import Config, replace

CUBE, LONG = 0, 1


def tiny_config(**overrides) -> Config:
    return replace(Config(), **{
        "scene.shapes": ("cube", "cuboid_long"), "scene.copies_per_shape": 1,
        "scene.max_objects": 2, "stage1.max_objects": 2, "stage2.max_objects": 2, "stage3.max_objects": 2,
        # The first benchmark's scene draw (spread-out drops, exact palette colours): these
        # tests check the physics of scripted grasps and resets; piles are tested in
        # test_clutter.py.
        "scene.placement": "scatter", "scene.colour_jitter": 0.0, **overrides,
    })


def yaw_quat(theta):
    """(B,) -> (B, 4) wxyz rotation about z."""
    return jnp.stack([jnp.cos(theta / 2), 0 * theta, 0 * theta, jnp.sin(theta / 2)], axis=-1)


def scenarios(n_cube: int, n_empty: int, n_long: int, n_pool: int, cfg: Config, seed: int = 0):
    """Worlds: n_cube isolated cubes grasped at their centre with a face-normal yaw (should
    succeed), n_empty grasps on empty spots (half with a cube elsewhere; should fail), n_long
    long cuboids grasped with the closing axis along their 10 cm length (should fail).

    Returns dict(pos (B,P,3), quat (B,P,4), active (B,P), position (B,3), yaw (B,)).
    """
    B = n_cube + n_empty + n_long
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-0.17, 0.17, (B, 2))
    theta = rng.uniform(-np.pi, np.pi, B)
    pos = np.zeros((B, n_pool, 3))
    quat = np.tile([1.0, 0, 0, 0], (B, n_pool, 1))
    active = np.zeros((B, n_pool), bool)
    grasp_xy = xy.copy()
    grasp_yaw = theta.copy()
    c = slice(0, n_cube)  # cubes: any face-normal yaw is correct
    pos[c, CUBE, :2], pos[c, CUBE, 2] = xy[c], 0.025
    quat[c, CUBE] = yaw_quat(theta[c])
    active[c, CUBE] = True
    grasp_yaw[c] = theta[c] + rng.integers(0, 4, n_cube) * np.pi / 2
    e = slice(n_cube, n_cube + n_empty)  # empty spots: half with a cube far away
    grasp_xy[e] = rng.uniform(0.05, 0.17, (n_empty, 2))
    pos[e, CUBE, :2], pos[e, CUBE, 2] = -grasp_xy[e], 0.025
    active[n_cube: n_cube + n_empty // 2, CUBE] = True
    lg = slice(n_cube + n_empty, B)  # long cuboid, closing axis along it: wrong by 90 deg
    pos[lg, LONG, :2], pos[lg, LONG, 2] = xy[lg], 0.025
    quat[lg, LONG] = yaw_quat(theta[lg])
    active[lg, LONG] = True
    z = np.where(active.any(1), 0.05 - cfg.grasp.depth_below_surface, -0.03)  # surface - 3 cm
    position = np.concatenate([grasp_xy, z[:, None]], axis=1)
    return dict(pos=pos, quat=quat, active=active, position=position, yaw=grasp_yaw)
