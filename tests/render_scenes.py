"""Small MJCF scenes for the camera / render / heightmap tests (independent of scene.py)."""
import math

import mujoco
import numpy as np

from vags_jax.config import Camera


def small_camera(scale: float = 0.1, **kw) -> Camera:
    """The default 640 x 480 camera scaled down (same field of view)."""
    base = Camera()
    return Camera(width=round(base.width * scale), height=round(base.height * scale),
                  fx=base.fx * scale, fy=base.fy * scale, **kw)


def _prism_vertices(radius, half_height, sides):
    ang = np.arange(sides) * 2 * math.pi / sides
    ring = np.stack([radius * np.cos(ang), radius * np.sin(ang)], -1)
    top = np.concatenate([ring, np.full((sides, 1), half_height)], -1)
    return np.concatenate([top, top * [1, 1, -1]])


def clutter_xml() -> str:
    """Floor plane, table box (top at z = 0), boxes, a convex prism mesh, a sphere, a capsule,
    a cylinder, and a group-3 "gripper" box that must not be rendered."""
    prism = " ".join(f"{v:.6f}" for v in _prism_vertices(0.03, 0.025, 12).ravel())
    wedge = " ".join(f"{v:.6f}" for v in np.array(
        [[-0.04, -0.02, 0], [0.04, -0.02, 0], [-0.04, 0.02, 0], [0.04, 0.02, 0],
         [-0.04, -0.02, 0.03], [-0.04, 0.02, 0.03]]).ravel())
    return f"""
<mujoco>
  <asset>
    <mesh name="prism" vertex="{prism}"/>
    <mesh name="wedge" vertex="{wedge}"/>
  </asset>
  <worldbody>
    <geom name="floor" type="plane" size="0 0 1" pos="0 0 -0.75" rgba=".5 .5 .5 1"/>
    <geom name="table" type="box" size="0.35 0.35 0.025" pos="0 0 -0.025" rgba=".8 .7 .6 1"/>
    <body pos="0.05 0.04 0.025" euler="0 0 30"><freejoint/>
      <geom name="cube" type="box" size="0.025 0.025 0.025" rgba="1 0 0 1"/></body>
    <body pos="-0.08 0.06 0.05" euler="0 0 -20"><freejoint/>
      <geom name="tall" type="box" size="0.025 0.025 0.05" rgba="0 1 0 1"/></body>
    <body pos="0.03 -0.09 0.0125" euler="0 0 70"><freejoint/>
      <geom name="flat" type="box" size="0.05 0.025 0.0125" rgba="0 0 1 1"/></body>
    <body pos="-0.10 -0.06 0.04" euler="20 10 40"><freejoint/>
      <geom name="tilted" type="box" size="0.03 0.02 0.015" rgba="1 1 0 1"/></body>
    <body pos="0.12 0.11 0.025" euler="0 0 10"><freejoint/>
      <geom name="prism" type="mesh" mesh="prism" rgba="1 0 1 1"/></body>
    <body pos="-0.13 0.14 0.0" euler="0 0 35"><freejoint/>
      <geom name="wedge" type="mesh" mesh="wedge" rgba="0 1 1 1"/></body>
    <body pos="0.14 -0.12 0.03"><freejoint/>
      <geom name="ball" type="sphere" size="0.03" rgba=".3 .6 .9 1"/></body>
    <body pos="0.0 0.15 0.02" euler="90 0 20"><freejoint/>
      <geom name="capsule" type="capsule" size="0.02 0.03" rgba=".9 .6 .3 1"/></body>
    <body pos="-0.15 -0.15 0.03"><freejoint/>
      <geom name="can" type="cylinder" size="0.025 0.03" rgba=".6 .3 .9 1"/></body>
    <body pos="0 0 0.45"><freejoint/>
      <geom name="gripper" type="box" size="0.05 0.05 0.02" group="3" rgba=".2 .2 .2 1"/></body>
  </worldbody>
</mujoco>"""


def one_box_xml(size=(0.03, 0.02, 0.025), pos=(0.04, -0.03), yaw_deg=25.0) -> str:
    """Table + one box resting on it (the box's top is at z = 2 * size[2])."""
    sx, sy, sz = size
    return f"""
<mujoco><worldbody>
  <geom name="table" type="box" size="0.35 0.35 0.025" pos="0 0 -0.025" rgba=".8 .7 .6 1"/>
  <body pos="{pos[0]} {pos[1]} {sz}" euler="0 0 {yaw_deg}"><freejoint/>
    <geom name="box" type="box" size="{sx} {sy} {sz}" rgba="1 0 0 1"/></body>
</worldbody></mujoco>"""


def load(xml: str):
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    return m, d


def mj_ray_depth(m, d, cam_pose: np.ndarray, cam: Camera, geomgroup=(1, 1, 1, 0, 1, 1)):
    """Reference z-depth image (h, w) from MuJoCo C's mj_multiRay (nan where nothing is hit)."""
    cx, cy = cam.principal_point
    u, v = np.meshgrid(np.arange(cam.width), np.arange(cam.height))
    rays = np.stack([(u - cx) / cam.fx, (v - cy) / cam.fy, np.ones_like(u, float)], -1).reshape(-1, 3)
    dirs = rays @ np.asarray(cam_pose, np.float64)[:3, :3].T
    n = len(dirs)
    geomid = np.zeros(n, np.int32)
    dist = np.zeros(n)
    mujoco.mj_multiRay(m, d, np.asarray(cam_pose, np.float64)[:3, 3], dirs.ravel(),
                       np.asarray(geomgroup, np.uint8), 1, -1, geomid, dist, None, n, 1e9)
    dist = np.where(geomid >= 0, dist, np.nan)
    return dist.reshape(cam.height, cam.width), geomid.reshape(cam.height, cam.width)
