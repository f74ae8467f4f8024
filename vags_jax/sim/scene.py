"""Scene construction: table, floating gripper and a pool of graspable blocks.

``build_scene(cfg)`` loads ``scenes/base.xml`` (table, floor, floating RG2-like gripper) with
``mujoco.MjSpec``, applies the solver settings and gripper limits from the Config, and adds the
object POOL: ``P = len(cfg.scene.shapes) * cfg.scene.copies_per_shape`` free bodies, each with
exactly one collision geom.  Pool index ``i`` has shape ``cfg.scene.shapes[i // copies]``.
Every reset (see ``vags_jax.sim.simulator``) draws its 1..N objects from the pool at random, so scenes get
random shapes; the bodies not drawn are parked.

Shapes (``SHAPES``): the 8 VPG blocks at their sizes plus a triangular prism and a half
cylinder.  Boxes are MuJoCo boxes; every round or slanted shape is a convex mesh generated here
(an extruded polygon, 16 sides for round profiles), because MJX impl "jax" does not collide
cylinders with boxes.  The arch is approximated by its convex outer outline (a Roman-arch
profile: straight sides, elliptic top), which is what a top-down parallel-jaw grasp can feel.
All body frames sit at the shape's bounding-box centre (the geom's frame may be offset by
MuJoCo to the mesh centroid); ``SceneModel.object_radius`` is the half bounding-box diagonal.

Parking objects (unused pool bodies and grasped objects): each pool body ``i`` has a fixed park
pose ``park_qpos[i]``, floating 0.5 m above the floor level at x = cx + 2.0 + 0.3 * (i % 10),
y = cy + 2.0 + 0.3 * (i // 10) (|x| > 1.5 m from the workspace centre, far outside any camera
view and 0.3 m apart, so a parked body touches nothing).  The simulator PINS parked bodies:
after every physics step their qpos is reset to the park pose and their velocity to zero (a
cheap masked select).  This costs no contacts (good for Warp's contact buffers), needs no
settling and never drifts, unlike letting them rest on the ground.

Parking the gripper: between grasps the gripper is teleported to ``gripper_park_qpos``:
TCP at (cx - 2.0, cy, table_z + 0.5), yaw 0, fingers fully open, all velocities zero, actuator
targets equal to that pose.  There it touches nothing (objects are never there, parked bodies
are on the other side).  The gripper is gravity compensated (body gravcomp = 1) and its geoms
are in MJCF geom group 3, never rendered.

Gripper geometry: joints gx, gy, gz (slides), gyaw (hinge), finger_l, finger_r (slides,
coupled by a joint equality).  qpos(gx, gy, gz) is the world position of the tool centre point
(TCP): the midpoint between the fingertips, i.e. the bottom edges of the two box pads
(24 x 8 x 70 mm, friction 1.5).  qpos(gyaw) is the angle of the closing axis in the world
xy-plane (fingers move along (cos yaw, sin yaw)).  Pad gap = q(finger_l) + q(finger_r), from
0 (touching) to ``cfg.grasp.finger_stroke`` (open; joint limits).  Pad contacts have priority
and a stiff solref (max(0.004, 2 * timestep)) so pads barely sink into what they press on.  Actuators: position servos on x, y, z,
yaw and one on the fingers with force limit ``cfg.grasp.grip_force``.
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Optional

import jax.numpy as jnp
import mujoco
import numpy as np

from vags_jax.config import Config

SCENES_DIR = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "scenes")
BASE_XML = os.path.join(SCENES_DIR, "base.xml")

# VPG's 10-colour palette (Tableau 10), uint8 RGB.
PALETTE = np.array(
    [
        [78, 121, 167],  # blue
        [89, 161, 79],  # green
        [156, 117, 95],  # brown
        [242, 142, 43],  # orange
        [237, 201, 72],  # yellow
        [186, 176, 172],  # gray
        [255, 87, 89],  # red
        [176, 122, 161],  # purple
        [118, 183, 178],  # cyan
        [255, 157, 167],  # pink
    ],
    dtype=np.uint8,
)

TABLE_RGB = (153, 153, 153)
GROUND_RGB = (77, 77, 77)
GRIPPER_RGB = (51, 51, 51)

# Parking layout (see module docstring).
PARK_OFFSET = 2.0  # m from the workspace centre
PARK_SPACING = 0.3  # m between parked bodies
PARK_HEIGHT = 0.5  # m above the table top
GRIPPER_PARK_OFFSET = (-2.0, 0.0, 0.5)  # TCP relative to (cx, cy, table_z)

# Collision bits (see scenes/base.xml).
OBJECT_CONTYPE, OBJECT_CONAFFINITY = 1, 3

# Rolling friction (m) of capsules and spheres: a capsule rolling at 0.5 m/s stops within ~10 cm.
ROLLING_FRICTION = 0.002

GRIPPER_JOINTS = ("gx", "gy", "gz", "gyaw", "finger_l", "finger_r")
GRIPPER_ACTUATORS = ("act_x", "act_y", "act_z", "act_yaw", "act_fingers")
FINGER_CLOSED_TARGET = -0.01  # finger servo target when closing (beyond touching: keeps squeezing)


@dataclass(frozen=True)
class Shape:
    """One object shape (a fixed block) or shape family (size drawn at every reset).

    kind: "box", "capsule", "sphere" or "mesh".  extents: full bounding box (dx, dy, dz) in
    metres, in the body frame; for a sized family, that of the nominal size the model is
    compiled with (the middle of its ranges).  vertices: (V, 3) convex-hull vertices in the
    body frame (bounding-box centre at 0), meshes only.  sized: the family's size is drawn per
    object and per world at every reset from the ``Scene`` config's ranges (``size_ranges``);
    fixed shapes keep ``extents``.
    """

    name: str
    kind: str
    extents: tuple[float, float, float]
    vertices: Optional[np.ndarray] = None
    sized: bool = False

    @property
    def radius(self) -> float:
        """Half the bounding-box diagonal: a bound on the distance of any point from the centre."""
        return 0.5 * float(np.linalg.norm(self.extents))


def _extrude_xz(profile: np.ndarray, length: float) -> np.ndarray:
    """Profile (K, 2) in the body x-z plane extruded along y -> vertices (2K, 3)."""
    k = profile.shape[0]
    y = np.full((k, 1), length / 2)
    a = np.concatenate([profile[:, :1], -y, profile[:, 1:]], axis=1)
    b = np.concatenate([profile[:, :1], y, profile[:, 1:]], axis=1)
    return np.concatenate([a, b], axis=0)


def _round_prism(diameter: float, height: float, sides: int = 16) -> np.ndarray:
    """Upright regular polygon prism (axis z) -> vertices (2 * sides, 3)."""
    t = 2 * np.pi * np.arange(sides) / sides  # vertices on the x and y axes: extents = diameter
    r = diameter / 2
    ring = np.stack([r * np.cos(t), r * np.sin(t)], axis=1)
    lo = np.concatenate([ring, np.full((sides, 1), -height / 2)], axis=1)
    hi = np.concatenate([ring, np.full((sides, 1), height / 2)], axis=1)
    return np.concatenate([lo, hi], axis=0)


def _centre(v: np.ndarray) -> np.ndarray:
    """Shift vertices so their bounding-box centre is the origin."""
    return v - 0.5 * (v.min(axis=0) + v.max(axis=0))


def _arch_vertices(width=0.093, depth=0.05, height=0.049, segments=8) -> np.ndarray:
    """Convex outline of VPG's arch: straight sides up to half height, elliptic top."""
    a, shoulder = width / 2, height / 2
    t = np.linspace(0.0, np.pi, segments + 1)
    top = np.stack([a * np.cos(t), shoulder + (height - shoulder) * np.sin(t)], axis=1)
    profile = np.concatenate([[[a, 0.0], [-a, 0.0]], top], axis=0)
    return _centre(_extrude_xz(profile, depth))


def _half_cylinder_vertices(radius=0.03, length=0.08, segments=12) -> np.ndarray:
    """Half cylinder lying on its flat face, axis along y."""
    t = np.linspace(0.0, np.pi, segments + 1)
    profile = np.stack([radius * np.cos(t), radius * np.sin(t)], axis=1)
    return _centre(_extrude_xz(profile, length))


def _triangular_prism_vertices(base=0.06, height=0.05, length=0.08) -> np.ndarray:
    """Prism lying on a rectangular face, triangular profile in x-z, axis along y."""
    profile = np.array([[-base / 2, 0.0], [base / 2, 0.0], [0.0, height]])
    return _centre(_extrude_xz(profile, length))


def _mesh_shape(name: str, v: np.ndarray) -> Shape:
    ext = tuple(float(e) for e in (v.max(axis=0) - v.min(axis=0)))
    return Shape(name, "mesh", ext, v.astype(np.float64))


SHAPES: dict[str, Shape] = {
    "cuboid_long": Shape("cuboid_long", "box", (0.10, 0.05, 0.05)),
    "cuboid_flat": Shape("cuboid_flat", "box", (0.10, 0.05, 0.025)),
    "cube": Shape("cube", "box", (0.05, 0.05, 0.05)),
    "cuboid_tall": Shape("cuboid_tall", "box", (0.05, 0.05, 0.10)),
    "cube_half": Shape("cube_half", "box", (0.05, 0.05, 0.025)),
    "arch": _mesh_shape("arch", _arch_vertices()),
    "disc": _mesh_shape("disc", _round_prism(0.06, 0.025)),
    "cylinder": _mesh_shape("cylinder", _round_prism(0.045, 0.05)),
    "prism": _mesh_shape("prism", _triangular_prism_vertices()),
    "half_cylinder": _mesh_shape("half_cylinder", _half_cylinder_vertices()),
    # Families whose size is drawn per object and per world at every reset (``size_ranges``).
    # Their extents here are the nominal ones of the compiled model (``nominal_size``).
    "box": Shape("box", "box", (0.05, 0.05, 0.05), sized=True),
    "capsule": Shape("capsule", "capsule", (0.045, 0.045, 0.085), sized=True),
    "sphere": Shape("sphere", "sphere", (0.05, 0.05, 0.05), sized=True),
}

# Object sets and pools: ``vags_jax.config.OBJECT_SETS`` and ``config.object_pool``.

# Kind codes per pool body (SceneModel.object_kind).
KIND_FIXED, KIND_BOX, KIND_CAPSULE, KIND_SPHERE = 0, 1, 2, 3


def size_ranges(shape: Shape, scene_cfg) -> tuple[np.ndarray, np.ndarray]:
    """(lo (3,), hi (3,)) of MuJoCo ``geom_size`` for one body of ``shape``.

    box: half sides, each drawn independently from ``scene_cfg.box_side`` / 2 (so proportions
    and volume vary); capsule: (radius, half length of the cylinder part, 0) from
    ``capsule_radius`` and ``capsule_length`` / 2; sphere: (radius, 0, 0) from
    ``sphere_radius``.  Fixed shapes: lo = hi = their compiled size (``nominal_size``).
    """
    if not shape.sized:
        v = nominal_size(shape, scene_cfg)
        return v, v
    if shape.kind == "box":
        lo, hi = scene_cfg.box_side
        return np.full(3, lo / 2), np.full(3, hi / 2)
    if shape.kind == "capsule":
        (r0, r1), (l0, l1) = scene_cfg.capsule_radius, scene_cfg.capsule_length
        return np.array([r0, l0 / 2, 0.0]), np.array([r1, l1 / 2, 0.0])
    if shape.kind == "sphere":
        r0, r1 = scene_cfg.sphere_radius
        return np.array([r0, 0.0, 0.0]), np.array([r1, 0.0, 0.0])
    raise ValueError(f"shape {shape.name!r} of kind {shape.kind!r} cannot be sized")


def nominal_size(shape: Shape, scene_cfg) -> np.ndarray:
    """(3,) MuJoCo ``geom_size`` the model is compiled with: fixed boxes their half extents,
    sized families the middle of their ranges; meshes (3,) zeros (MuJoCo sizes them)."""
    if shape.sized:
        lo, hi = size_ranges(shape, scene_cfg)
        return 0.5 * (lo + hi)
    if shape.kind == "box":
        return np.asarray(shape.extents, np.float64) / 2
    return np.zeros(3)


def sized_body_physics(kind, size, density: float):
    """Mass properties and bounds of single-geom bodies of drawn sizes (pure jnp, any batch).

    kind: (..., P) int32 kind codes (``KIND_*``); size: (..., P, 3) MuJoCo geom_size;
    density: kg/m^3.  Returns a dict of (..., P) ``mass``, (..., P, 3) ``inertia`` (principal,
    geom frame = body inertial frame), (..., P) ``rbound`` (MuJoCo's bounding-sphere radius),
    (..., P, 3) ``aabb_half`` (half extents of the geom-frame bounding box), (..., P, 2)
    ``invweight`` (MuJoCo's body_invweight0 of a free body: 1 / mass and the mean of
    1 / inertia) -- MuJoCo's own formulas for boxes, capsules and spheres (tests compare them
    with compiled models).  Rows of KIND_FIXED bodies are meaningless (callers keep the
    compiled values there).
    """

    s0, s1, s2 = size[..., 0], size[..., 1], size[..., 2]
    box, cap = kind == KIND_BOX, kind == KIND_CAPSULE
    # Box: half sides (a, b, c).
    box_m = density * 8 * s0 * s1 * s2
    box_i = box_m[..., None] / 3 * jnp.stack([s1**2 + s2**2, s0**2 + s2**2, s0**2 + s1**2], -1)
    # Capsule: radius r, cylinder half length h, along z.  Sphere: radius r.
    r, height = s0, 2 * s1
    cyl_v, sph_v = np.pi * r**2 * height, 4.0 / 3.0 * np.pi * r**3
    cap_m = density * (cyl_v + sph_v)
    m_sph, m_cyl = density * sph_v, density * cyl_v
    i_sph = 2 * m_sph * r**2 / 5
    i_xy = m_cyl * (3 * r**2 + height**2) / 12 + i_sph + m_sph * height * (3 * r + 2 * height) / 8
    cap_i = jnp.stack([i_xy, i_xy, m_cyl * r**2 / 2 + i_sph], -1)
    ball_m = density * sph_v
    ball_i = jnp.stack([i_sph, i_sph, i_sph], -1) * (ball_m / jnp.maximum(m_sph, 1e-30))[..., None]
    mass = jnp.where(box, box_m, jnp.where(cap, cap_m, ball_m))
    inertia = jnp.where(box[..., None], box_i, jnp.where(cap[..., None], cap_i, ball_i))
    rbound = jnp.where(box, jnp.sqrt(s0**2 + s1**2 + s2**2), jnp.where(cap, s0 + s1, s0))
    aabb_half = jnp.where(box[..., None], size,
                          jnp.stack([s0, s0, jnp.where(cap, s0 + s1, s0)], -1))
    safe_m = jnp.maximum(mass, 1e-12)
    invweight = jnp.stack([1.0 / safe_m, jnp.mean(1.0 / jnp.maximum(inertia, 1e-15), -1)], -1)
    return dict(mass=mass, inertia=inertia, rbound=rbound, aabb_half=aabb_half, invweight=invweight)


@dataclass
class SceneModel:
    """The compiled scene and the indices the simulator and renderer need (built once).

    P = pool size, ngeom = mj_model.ngeom.
    """

    cfg: Config
    mj_model: mujoco.MjModel
    shape_names: tuple[str, ...]  # (P,) shape name of each pool body
    object_body_ids: np.ndarray  # (P,) int32
    object_geom_ids: np.ndarray  # (P,) int32, one geom per object
    object_qpos_adr: np.ndarray  # (P,) int32, start of the 7 free-joint qpos (pos, quat wxyz)
    object_dof_adr: np.ndarray  # (P,) int32, start of the 6 free-joint dofs
    object_shape_index: np.ndarray  # (P,) int32 index into cfg.scene.shapes
    object_radius: np.ndarray  # (P,) float32, half bounding-box diagonal (nominal size)
    object_half_height: np.ndarray  # (P,) float32, half z extent when resting upright (nominal)
    object_kind: np.ndarray  # (P,) int32 KIND_* code (KIND_FIXED: size never changes)
    object_size: np.ndarray  # (P, 3) float32 compiled (nominal) MuJoCo geom_size
    object_size_lo: np.ndarray  # (P, 3) float32 drawn geom_size range (lo = hi for fixed shapes)
    object_size_hi: np.ndarray  # (P, 3) float32
    park_qpos: np.ndarray  # (P, 7) float32
    park_qpos_full: np.ndarray  # (nq,) float32: everything parked (also keyframe "park")
    park_ctrl: np.ndarray  # (nu,) float32: servo targets holding the parked gripper
    gripper_qpos_adr: np.ndarray  # (6,) int32: gx, gy, gz, gyaw, finger_l, finger_r
    gripper_dof_adr: np.ndarray  # (6,) int32
    gripper_actuator_ids: np.ndarray  # (5,) int32: x, y, z, yaw, fingers
    gripper_park_qpos: np.ndarray  # (6,) float32
    pad_geom_ids: np.ndarray  # (2,) int32
    table_geom_id: int
    ground_geom_id: int
    table_collider_geom_id: int
    render_geom_mask: np.ndarray  # (ngeom,) bool: table, ground, objects
    default_geom_rgb: np.ndarray  # (ngeom, 3) uint8
    palette: np.ndarray  # (10, 3) uint8

    @property
    def pool_size(self) -> int:
        return int(self.object_body_ids.shape[0])

    @property
    def has_sized_objects(self) -> bool:
        """True when some pool body's size is drawn per reset (per-world model fields)."""
        return bool((self.object_kind != KIND_FIXED).any())

    @property
    def max_objects(self) -> int:
        return self.cfg.scene.max_objects

    @property
    def finger_open(self) -> float:
        """Finger joint value (each) when fully open."""
        return self.cfg.grasp.finger_stroke / 2


def _park_position(cfg: Config, i: int) -> tuple[float, float, float]:
    cx, cy = cfg.workspace.center
    return (
        cx + PARK_OFFSET + PARK_SPACING * (i % 10),
        cy + PARK_OFFSET + PARK_SPACING * (i // 10),
        cfg.workspace.table_z + PARK_HEIGHT,
    )


def rows_per_contact(cfg: Config) -> int:
    """Constraint rows of one contact at most: 6 when a pool body rolls (condim 6), else 3."""
    return 6 if any(SHAPES[n].kind in ("capsule", "sphere") for n in cfg.scene.shapes if n in SHAPES) else 3


def contacts_per_world(cfg: Config) -> int:
    """Contact budget of one world: ``cfg.sim.contacts_per_world`` or 20 * N + 56.

    Only active objects and the gripper can touch anything (parked bodies are pinned far
    apart): each object on the table has up to 4 contacts, object-object ~16 per object,
    2 pads x up to 3 objects x 8, pads on the table 8.
    """
    if cfg.sim.contacts_per_world is not None:
        return int(cfg.sim.contacts_per_world)
    return 20 * cfg.scene.max_objects + 56


# Long (one reason): the MjSpec edits are one recipe, read top to bottom.
def build_spec(cfg: Config) -> mujoco.MjSpec:
    """The MjSpec of the full scene (base assets + object pool), not yet compiled."""
    for name in cfg.scene.shapes:
        if name not in SHAPES:
            raise ValueError(
                f"Scene.shapes names unknown shape {name!r}; known shapes: {sorted(SHAPES)}"
            )
    spec = mujoco.MjSpec.from_file(BASE_XML)
    opt = spec.option
    opt.timestep = cfg.sim.timestep
    opt.iterations = cfg.sim.iterations
    opt.ls_iterations = cfg.sim.ls_iterations
    opt.impratio = cfg.sim.impratio
    opt.cone = {"elliptic": mujoco.mjtCone.mjCONE_ELLIPTIC,
                "pyramidal": mujoco.mjtCone.mjCONE_PYRAMIDAL}[cfg.sim.cone]
    opt.ccd_iterations = cfg.sim.ccd_iterations
    if not cfg.sim.native_ccd:
        opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_NATIVECCD
    if not cfg.sim.multi_ccd:
        opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_MULTICCD
    opt.solver = {"newton": mujoco.mjtSolver.mjSOL_NEWTON, "cg": mujoco.mjtSolver.mjSOL_CG}[cfg.sim.solver]
    opt.tolerance = cfg.sim.tolerance
    if cfg.sim.sleep:
        opt.enableflags |= mujoco.mjtEnableBit.mjENBL_SLEEP
        opt.sleep_tolerance = cfg.sim.sleep_tolerance

    tz = cfg.workspace.table_z
    cx, cy = cfg.workspace.center
    for g in spec.geoms:
        if g.name in ("table_collider", "table", "ground"):
            g.pos = [cx if g.name == "table" else 0.0, cy if g.name == "table" else 0.0,
                     g.pos[2] + tz]
        if g.name == "table_collider":
            g.friction = [cfg.scene.friction, 0.005, 0.0001]
        if g.name in ("pad_l", "pad_r"):  # stiff pad contacts (see scenes/base.xml)
            g.solref = [max(0.004, 2 * cfg.sim.timestep), 1.0]

    # Gripper servo ranges and the grip force from the config.
    stroke_half = cfg.grasp.finger_stroke / 2
    for a in spec.actuators:
        if a.name == "act_fingers":
            a.ctrlrange = [FINGER_CLOSED_TARGET, stroke_half]
            a.forcerange = [-cfg.grasp.grip_force, cfg.grasp.grip_force]
        elif a.name in ("act_x", "act_y"):
            c = cx if a.name == "act_x" else cy
            a.ctrlrange = [c - 3.0, c + 3.0]
        elif a.name == "act_z":
            a.ctrlrange = [tz - 1.0, tz + 2.0]

    for j in spec.joints:
        if j.name in ("finger_l", "finger_r"):
            j.range = [0.0, stroke_half]

    # MJX impl "jax" evaluates every candidate geom pair with fixed contact slots (about 1000
    # contacts, 3000 constraint rows per world for the default pool); keep only the deepest
    # ``contacts_per_world`` so the solver works on a scene-sized problem (ignored by C / warp).
    num = spec.add_numeric()
    num.name = "max_contact_points"
    num.data = [float(contacts_per_world(cfg))]

    # The eye-in-hand camera for MJX's Warp renderer (vags_jax.perception.render, backend "warp"): its pose
    # is overwritten per world at render time; physics does not see it.
    spec.worldbody.add_camera(name="vags_cam", pos=list(cfg.camera.global_position))

    # Object pool.
    copies = cfg.scene.copies_per_shape
    for s_idx, name in enumerate(cfg.scene.shapes):
        shape = SHAPES[name]
        if shape.kind == "mesh" and spec.mesh(f"mesh_{name}") is None:  # a pool may repeat a shape
            mesh = spec.add_mesh()
            mesh.name = f"mesh_{name}"
            mesh.uservert = shape.vertices.reshape(-1).tolist()
        for c in range(copies):
            i = s_idx * copies + c
            body = spec.worldbody.add_body()
            body.name = f"obj_{i}"
            body.pos = list(_park_position(cfg, i))
            body.add_freejoint().name = f"obj_{i}_free"
            g = body.add_geom()
            g.name = f"obj_{i}_geom"
            if shape.kind in ("box", "capsule", "sphere"):
                g.type = {"box": mujoco.mjtGeom.mjGEOM_BOX, "capsule": mujoco.mjtGeom.mjGEOM_CAPSULE,
                          "sphere": mujoco.mjtGeom.mjGEOM_SPHERE}[shape.kind]
                g.size = nominal_size(shape, cfg.scene).tolist()
            else:
                g.type = mujoco.mjtGeom.mjGEOM_MESH
                g.meshname = f"mesh_{name}"
            g.contype, g.conaffinity = OBJECT_CONTYPE, OBJECT_CONAFFINITY
            g.friction = [cfg.scene.friction, 0.005, 0.0001]
            if shape.kind in ("capsule", "sphere"):
                # Round bodies get rolling friction (condim 6), or a capsule dropped on a pile
                # rolls off the workspace (with condim 3, one in ~5 tiny piles lost an object).
                g.condim = 6
                g.friction = [cfg.scene.friction, 0.005, ROLLING_FRICTION]
            g.density = cfg.scene.object_density
            g.group = 0
            rgb = PALETTE[i % len(PALETTE)] / 255.0  # (per-world colours are drawn at reset)
            g.rgba = [float(rgb[0]), float(rgb[1]), float(rgb[2]), 1.0]
    return spec


# Long (one reason): the compiled model's index tables, gathered in one place for the simulator.
def build_scene(cfg: Config) -> SceneModel:
    """Compile the scene for ``cfg`` and collect its indices.  Called once per run."""
    spec = build_spec(cfg)
    m = spec.compile()
    P = cfg.scene.pool_size
    copies = cfg.scene.copies_per_shape

    def jid(name):
        return mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)

    def gid(name):
        return mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, name)

    body_ids = np.array(
        [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, f"obj_{i}") for i in range(P)], np.int32
    )
    geom_ids = np.array([gid(f"obj_{i}_geom") for i in range(P)], np.int32)
    jnt = [jid(f"obj_{i}_free") for i in range(P)]
    qadr = np.array([m.jnt_qposadr[j] for j in jnt], np.int32)
    dadr = np.array([m.jnt_dofadr[j] for j in jnt], np.int32)
    shape_index = np.array([i // copies for i in range(P)], np.int32)
    names = tuple(cfg.scene.shapes[k] for k in shape_index)
    radius = np.array([SHAPES[n].radius for n in names], np.float32)
    half_h = np.array([SHAPES[n].extents[2] / 2 for n in names], np.float32)
    kinds = {"box": KIND_BOX, "capsule": KIND_CAPSULE, "sphere": KIND_SPHERE}
    kind = np.array([kinds[SHAPES[n].kind] if SHAPES[n].sized else KIND_FIXED for n in names], np.int32)
    size0 = np.asarray(m.geom_size[geom_ids], np.float32)
    lo, hi = size0.copy(), size0.copy()
    for i, n in enumerate(names):
        if SHAPES[n].sized:
            lo[i], hi[i] = size_ranges(SHAPES[n], cfg.scene)
    park = np.array([list(_park_position(cfg, i)) + [1.0, 0.0, 0.0, 0.0] for i in range(P)],
                    np.float32)

    gj = [jid(n) for n in GRIPPER_JOINTS]
    g_qadr = np.array([m.jnt_qposadr[j] for j in gj], np.int32)
    g_dadr = np.array([m.jnt_dofadr[j] for j in gj], np.int32)
    g_act = np.array(
        [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, n) for n in GRIPPER_ACTUATORS], np.int32
    )
    cx, cy = cfg.workspace.center
    ox, oy, oz = GRIPPER_PARK_OFFSET
    stroke_half = cfg.grasp.finger_stroke / 2
    g_park = np.array(
        [cx + ox, cy + oy, cfg.workspace.table_z + oz, 0.0, stroke_half, stroke_half], np.float32
    )

    table, ground, collider = gid("table"), gid("ground"), gid("table_collider")
    mask = np.zeros(m.ngeom, bool)
    mask[[table, ground]] = True
    mask[geom_ids] = True
    rgb = np.tile(np.array(GRIPPER_RGB, np.uint8), (m.ngeom, 1))
    rgb[table], rgb[ground] = TABLE_RGB, GROUND_RGB
    rgb[geom_ids] = PALETTE[np.arange(P) % len(PALETTE)]

    # Keyframe "park": every object and the gripper parked (slide joints have qpos0 = 0, so
    # their qpos is the world TCP coordinate; qpos0 itself must stay 0).
    full = np.array(m.qpos0, np.float64)
    for i in range(P):
        full[qadr[i]: qadr[i] + 7] = park[i]
    full[g_qadr] = g_park
    key = spec.add_key()
    key.name = "park"
    key.qpos = full.tolist()
    ctrl = np.zeros(m.nu)
    ctrl[g_act] = np.append(g_park[:4], stroke_half)
    key.ctrl = ctrl.tolist()
    m = spec.compile()

    return SceneModel(
        cfg=cfg,
        mj_model=m,
        shape_names=names,
        object_body_ids=body_ids,
        object_geom_ids=geom_ids,
        object_qpos_adr=qadr,
        object_dof_adr=dadr,
        object_shape_index=shape_index,
        object_radius=radius,
        object_half_height=half_h,
        object_kind=kind,
        object_size=size0,
        object_size_lo=lo,
        object_size_hi=hi,
        park_qpos=park,
        park_qpos_full=full.astype(np.float32),
        park_ctrl=ctrl.astype(np.float32),
        gripper_qpos_adr=g_qadr,
        gripper_dof_adr=g_dadr,
        gripper_actuator_ids=g_act,
        gripper_park_qpos=g_park,
        pad_geom_ids=np.array([gid("pad_l"), gid("pad_r")], np.int32),
        table_geom_id=table,
        ground_geom_id=ground,
        table_collider_geom_id=collider,
        render_geom_mask=mask,
        default_geom_rgb=rgb,
        palette=PALETTE.copy(),
    )
