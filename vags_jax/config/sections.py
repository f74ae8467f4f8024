"""Frozen configuration dataclasses for every part of vags_jax.

Conventions shared by all modules (read these before writing code against them):

* World frame: z up, the table top is the plane ``z = Workspace.table_z`` (default 0).
  The workspace is the square of side ``Workspace.size`` centred at ``Workspace.center``.
* Heightmaps are ``(H, W) = (heightmap_px, heightmap_px)`` arrays; row index follows +y,
  column index follows +x (as in VPG).  Cell ``(row, col)`` covers
  ``x in [xmin + col * px, xmin + (col + 1) * px)`` and the same for ``y`` with ``row``.
  Heights are metres above the table, 0 where no point falls.
* Grasp rotations: index ``r in 0..n_rotations-1`` means angle ``theta = r * pi / 8``
  (for 16 rotations; ``Grasp.rotation_step``).  The gripper's *closing axis* (the line the
  fingers move along) points along ``(cos theta, sin theta)`` in the world xy-plane, i.e. along
  (col, row) in the heightmap.  ``r`` and ``r + 8`` are the same physical grasp, which GDNet
  judges on heightmaps turned 180 degrees apart.  With ``Grasp.half_turn`` the rotations span
  half a turn instead (``theta = r * pi / n_rotations``): every index is a different grasp, and
  8 half-turn rotations are the 8 distinct grasps of 16 full-turn ones at half the network cost.
* Cameras use the OpenCV convention: x right, y down, z forward (optical axis).  A pose is a
  ``(4, 4)`` camera-to-world transform.  Depth images hold the z-distance along the optical
  axis in metres (as RGB-D sensors report), 0 where nothing was hit or the pixel is missing.

Every config validates itself in ``__post_init__`` and raises ``ValueError`` naming the field
and what to change.  First every field is type-checked against its annotation
(``@checked``, ``vags_jax.config.validation``: ints are ints and never bools or floats, even
``1e3``; floats are finite; tuples have their length; ``Optional`` takes ``None``), so a field
added later is checked with no extra code; then each class checks its ranges, with upper
bounds on sizes where memory or int32 indices bite (``MAX_*`` below).  ``replace`` (and so
``--set``) names a bad value by its dotted key, e.g. ``stage1.n_worlds``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional

from vags_jax.config.validation import checked


def _check(cond: bool, msg: str) -> None:
    if not cond:
        raise ValueError(msg)


def _within(label: str, value, lo, hi, unit: str = "", lo_open: bool = False, hi_open: bool = False) -> None:
    """Range check with a message like ``Scene.friction must be in (0, 10], got -1``."""
    ok_lo = value > lo if lo_open else value >= lo
    ok_hi = value < hi if hi_open else value <= hi
    _check(ok_lo and ok_hi,
           f"{label} must be in {'(' if lo_open else '['}{_num(lo)}, {_num(hi)}{')' if hi_open else ']'}"
           f"{' ' + unit if unit else ''}, got {_num(value)}")


def _num(v) -> str:
    return f"{v:,}" if isinstance(v, int) else f"{v:g}"


# Upper bounds on sizes.  A heightmap cell costs 10 bytes per stored transition (uint8 colour and
# float16 height, before and after the grasp), so the replay buffer's memory is
# capacity * 10 * heightmap_px**2 bytes; the largest accelerator the project targets (H200)
# holds 141 GB.  Q maps of all worlds are n_worlds * n_rotations * heightmap_px**2 values of at
# least 2 bytes (bfloat16).
MAX_HEIGHTMAP_PX = 1024
MAX_IMAGE_SIDE = 4096  # camera width / height, pixels
MAX_WORLDS = 1 << 20
MAX_DEVICE_BYTES = 128 * 2**30  # replay buffer, and Q maps of all worlds
REPLAY_BYTES_PER_CELL = 10


# ----------------------------------------------------------------------------- world


@dataclass(frozen=True)
@checked
class Workspace:
    """The square table region the robot works in and its heightmap grid."""

    center: tuple[float, float] = (0.0, 0.0)
    size: float = 0.448  # metres, side of the square
    heightmap_px: int = 224  # cells per side -> 2 mm/px at the defaults
    table_z: float = 0.0  # height of the table top in the world frame

    def __post_init__(self):
        _check(self.size > 0, f"Workspace.size must be > 0 metres, got {self.size}")
        _within("Workspace.size", self.size, 0, 5.0, "metres", lo_open=True)
        _check(
            isinstance(self.heightmap_px, int) and self.heightmap_px >= 8,
            f"Workspace.heightmap_px must be an int >= 8, got {self.heightmap_px!r}",
        )
        _within("Workspace.heightmap_px", self.heightmap_px, 8, MAX_HEIGHTMAP_PX)
        for v in self.center:
            _within("Workspace.center", v, -10.0, 10.0, "metres")
        _within("Workspace.table_z", self.table_z, -10.0, 10.0, "metres")

    @property
    def pixel_size(self) -> float:
        return self.size / self.heightmap_px

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, xmax, ymin, ymax) in metres."""
        cx, cy = self.center
        h = self.size / 2
        return (cx - h, cx + h, cy - h, cy + h)


# Object sets: the pool of a scene (``Scene.shapes``) is drawn from one of them (shape
# geometry and the size ranges live in ``vags_jax.sim.scene``).
#   train:  cuboids whose three sides are each drawn from ``Scene.box_side`` (cubes, flat, long
#           and tall blocks and everything between) and capsules of drawn radius and length.
#           The training and default benchmark set.
#   unseen: held out (never trained on): arch, triangular prism, half cylinder, disc and upright
#           cylinder at VPG's block sizes, and spheres of a drawn radius.  No (shape, size
#           range) is shared with ``train``.  ``eval.py --objects unseen``.
#   legacy: the ten fixed-size blocks of the first benchmark (VPG's 8 blocks + prism + half
#           cylinder), for comparisons with earlier results.
OBJECT_SETS: dict[str, tuple[str, ...]] = {
    "train": ("box", "capsule", "box", "box", "capsule"),
    "unseen": ("arch", "prism", "half_cylinder", "disc", "cylinder", "sphere"),
    "legacy": ("cuboid_long", "cuboid_flat", "cube", "cuboid_tall", "cube_half", "arch",
               "disc", "cylinder", "prism", "half_cylinder"),
}


def object_pool(set_name: str, n: int) -> tuple[str, ...]:
    """A pool of ``n`` bodies: object set ``set_name``'s shapes repeated cyclically.

    With 10 slots, ``train`` gives 6 boxes and 4 capsules; ``unseen`` each of its six shapes
    once or twice; ``legacy`` its ten blocks once.
    """
    if set_name not in OBJECT_SETS:
        raise ValueError(f"unknown object set {set_name!r}; choose one of {sorted(OBJECT_SETS)}")
    if not (isinstance(n, int) and not isinstance(n, bool) and n >= 1):
        raise ValueError(f"object_pool needs n >= 1 bodies, got {n!r}")
    names = OBJECT_SETS[set_name]
    return tuple(names[i % len(names)] for i in range(n))


PLACEMENTS = ("pile", "scatter")

# The "edge" scene variant, after the paper's failure case ("some objects are located at the
# edge of the field of view"): the global camera on the default's line of sight, moved in until
# the workspace's near edge touches the image's bottom border (the far edge is seen at the
# coarsest resolution), and piles dropped anywhere that keeps their drop positions 3.5 cm inside
# the workspace edge, so objects reach the edges.  Chosen by that geometry alone, not by
# results; the default scenes stay the benchmark's.  ``eval.py --scenes edge``, or the
# ``gpu-edge`` preset for training.
EDGE_SCENES = {
    "scene.drop_margin": 0.06,
    "camera.global_position": (0.0, -0.34, 0.502),
}

# The first benchmark's scenes (before the paper's protocol was followed): the ten fixed blocks
# dropped apart, exact palette colours, a noiseless camera 23 deg off vertical.  For comparisons
# with results measured on them (``eval.py --scenes legacy``); ``--set`` pairs.
LEGACY_SCENES = {
    "scene.shapes": OBJECT_SETS["legacy"],
    "scene.placement": "scatter",
    "scene.colour_jitter": 0.0,
    "camera.noise.enabled": False,
    "camera.global_position": (0.0, -0.25, 0.60),
}


def _check_range(name: str, r, lo_bound: float, hi_bound: float) -> None:
    _check(
        isinstance(r, (tuple, list)) and len(r) == 2
        and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in r),
        f"{name} must be a range (min, max) of two numbers in metres, got {r!r}",
    )
    _check(r[0] <= r[1], f"{name} = {tuple(r)}: min > max; give (min, max)")
    _check(lo_bound <= r[0] and r[1] <= hi_bound,
           f"{name} = {tuple(r)} must lie within [{lo_bound}, {hi_bound}] m (positive sizes the "
           "gripper can still hold)")


@dataclass(frozen=True)
@checked
class Scene:
    """Objects on the table.  ``max_objects`` is N, the number of object slots per world.

    The default follows the paper's protocol (section 4): every reset draws each object's
    shape (from the pool), size and colour per world, and drops the objects one after another
    over a small region so that they land on each other (``placement = "pile"``).
    """

    max_objects: int = 10
    # Names from vags_jax.sim.scene.SHAPES; the pool holds `copies_per_shape` bodies of each,
    # and each reset draws its objects from that pool (random shapes per reset).
    # Default: object_pool("train", 10) = 6 boxes and 4 capsules of drawn sizes.
    shapes: tuple[str, ...] = ("box", "capsule", "box", "box", "capsule",
                               "box", "capsule", "box", "box", "capsule")
    copies_per_shape: int = 1  # 1: the pool is the N = 10 object slots (1.5x faster physics than 2)
    # Size ranges of the drawn families (metres).  Box: each of the three sides drawn
    # independently (volume 16 cm^3 .. 512 cm^3 at the defaults, around VPG's 2.5-10 cm
    # blocks; at most 8 cm so one side always fits the 8.5 cm stroke).  Capsule: radius and
    # the length of its cylinder part.  Sphere (unseen set only): radius.
    box_side: tuple[float, float] = (0.025, 0.08)
    capsule_radius: tuple[float, float] = (0.015, 0.03)
    capsule_length: tuple[float, float] = (0.02, 0.08)
    sphere_radius: tuple[float, float] = (0.018, 0.03)
    # Colours: a palette colour per object (distinct within a world for up to 10 objects),
    # each channel scaled by a factor drawn from [1 - colour_jitter, 1 + colour_jitter].
    colour_jitter: float = 0.15
    # "pile": objects dropped one after another (stacked spawn heights, lowest first) over a
    # disc of radius ``pile_radius`` at a random centre, so they land on each other: stacks,
    # leaning objects, occlusion.  "scatter": x, y uniform over the workspace shrunk by
    # ``drop_margin`` (the first benchmark's scenes).
    placement: str = "pile"
    pile_radius: float = 0.025  # m (drop positions; the pile spreads wider as objects land and tip)
    drop_height: float = 0.15  # m above the table (the lowest object's centre)
    drop_margin: float = 0.1  # m kept clear of the workspace edge when dropping
    settle_time: float = 1.0  # s of simulation after dropping
    friction: float = 1.0  # sliding friction of objects and table
    object_density: float = 500.0  # kg/m^3

    def __post_init__(self):
        _check(
            isinstance(self.max_objects, int) and self.max_objects >= 1,
            f"Scene.max_objects must be an int >= 1, got {self.max_objects!r}",
        )
        _check(len(self.shapes) >= 1, "Scene.shapes must name at least one shape")
        _check(
            self.copies_per_shape >= 1,
            f"Scene.copies_per_shape must be >= 1, got {self.copies_per_shape}",
        )
        _check(
            len(self.shapes) * self.copies_per_shape >= self.max_objects,
            f"Scene: the object pool has len(shapes) * copies_per_shape = "
            f"{len(self.shapes) * self.copies_per_shape} bodies but max_objects = "
            f"{self.max_objects}; raise copies_per_shape or lower max_objects",
        )
        _check(self.settle_time >= 0, "Scene.settle_time must be >= 0 seconds")
        _within("Scene.max_objects", self.max_objects, 1, 100)
        _within("Scene.copies_per_shape", self.copies_per_shape, 1, 100)
        _within("Scene.settle_time", self.settle_time, 0, 10.0, "seconds")
        _within("Scene.drop_height", self.drop_height, 0, 1.0, "metres", lo_open=True)
        _within("Scene.drop_margin", self.drop_margin, 0, 1.0, "metres")
        _within("Scene.friction", self.friction, 0, 10.0, lo_open=True)
        _within("Scene.object_density", self.object_density, 0, 1e5, "kg/m^3", lo_open=True)
        _check_range("Scene.box_side", self.box_side, 0.005, 0.08)
        _check_range("Scene.capsule_radius", self.capsule_radius, 0.005, 0.04)
        _check_range("Scene.capsule_length", self.capsule_length, 0.0, 0.15)
        _check_range("Scene.sphere_radius", self.sphere_radius, 0.005, 0.04)
        _check(isinstance(self.colour_jitter, (int, float)) and 0.0 <= self.colour_jitter <= 0.5,
               f"Scene.colour_jitter must be in [0, 0.5], got {self.colour_jitter!r}")
        _check(self.placement in PLACEMENTS,
               f"Scene.placement must be one of {PLACEMENTS}, got {self.placement!r}")
        _check(self.placement != "pile" or self.settle_time >= 0.2,
               f"Scene.placement = 'pile' drops its objects one after another during the first half "
               f"of Scene.settle_time, which must then be >= 0.2 s (got {self.settle_time}); raise it, "
               "or use scene.placement=scatter")
        _check(isinstance(self.pile_radius, (int, float)) and 0.0 <= self.pile_radius <= 0.2,
               f"Scene.pile_radius must be in [0, 0.2] m, got {self.pile_radius!r}")

    @property
    def pool_size(self) -> int:
        return len(self.shapes) * self.copies_per_shape


@dataclass(frozen=True)
@checked
class Sim:
    """Physics settings.  ``impl`` is MJX's backend: "jax" (any device) or "warp" (GPU)."""

    impl: str = "jax"
    # s per physics step; MJX jax needs 2 ms, warp holds 6 ms (bench/RESULTS.md, "Environment throughput",
    # 4th/6th pass)
    timestep: float = 0.002
    # Newton solver cap and line-search iterations: 10 and 20 keep objects on the table under MJX
    # jax; the ``gpu`` preset's cap of 2 keeps warp's grasp outcomes (bench/RESULTS.md, "Environment
    # throughput", 7th pass).
    iterations: int = 10
    ls_iterations: int = 20
    impratio: float = 10.0  # friction-to-normal impedance ratio (elliptic cones); ``tiny`` uses 1
    solver: str = "newton"  # MuJoCo constraint solver: "newton" or "cg"
    tolerance: float = 1e-8  # MuJoCo opt.tolerance: the solver stops early below this improvement
    # Contact / constraint buffers.  None -> sized from the scene (see vags_jax/sim/buffers.py).
    naconmax: Optional[int] = None  # warp: contacts across all worlds
    njmax: Optional[int] = None  # warp: constraint rows per world
    # Contact budget per world.  jax: MJX "max_contact_points" (the deepest contacts are kept; cuts
    # constraint rows); warp: naconmax = B * this when naconmax is None.
    # None -> 20 * scene.max_objects + 56 (see vags_jax/sim/buffers.py).  Overflow is flagged in SimState.overflow.
    contacts_per_world: Optional[int] = None
    # MuJoCo sleeping (impl "warp" only): bodies at rest stop being simulated until touched; off in
    # every preset, it cost attempts/s in the H100 training loop (bench/RESULTS.md, "Environment throughput",
    # 5th pass).
    sleep: bool = False
    sleep_tolerance: float = 1e-3
    # Friction cone: "elliptic" or "pyramidal" (faster on warp, but objects slip out of the pads;
    # no preset uses it: bench/RESULTS.md, "Environment throughput", 6th pass).
    cone: str = "elliptic"
    # Convex collision: MuJoCo's GJK / EPA iteration cap; ``native_ccd`` False uses MuJoCo's primitive
    # box-box test (the ``gpu`` preset).  Impl "warp" and MuJoCo C honour both; MJX jax ignores them.
    ccd_iterations: int = 35
    native_ccd: bool = True
    # ``multi_ccd`` False: one contact per convex pair; faster, but resting meshes rock (bench/RESULTS.md,
    # "Environment throughput", 6th pass).
    multi_ccd: bool = True

    def __post_init__(self):
        _check(
            self.impl in ("jax", "warp"),
            f"Sim.impl must be 'jax' or 'warp', got {self.impl!r}",
        )
        _check(0 < self.timestep <= 0.01, f"Sim.timestep must be in (0, 0.01] s, got {self.timestep}")
        _check(self.iterations >= 1, "Sim.iterations must be >= 1")
        _check(self.ls_iterations >= 1, "Sim.ls_iterations must be >= 1")
        _check(self.solver in ("newton", "cg"), f"Sim.solver must be 'newton' or 'cg', got {self.solver!r}")
        _check(0 <= self.tolerance < 1, f"Sim.tolerance must be in [0, 1), got {self.tolerance}")
        _check(
            not self.sleep or (self.impl == "warp" and self.solver == "newton"),
            f"Sim.sleep = True needs impl 'warp' and solver 'newton' (MuJoCo Warp sleeps, MJX jax "
            f"does not), got impl {self.impl!r}, solver {self.solver!r}; set sim.sleep=false",
        )
        _check(self.sleep_tolerance > 0, f"Sim.sleep_tolerance must be > 0, got {self.sleep_tolerance}")
        _check(self.cone in ("elliptic", "pyramidal"),
               f"Sim.cone must be 'elliptic' or 'pyramidal', got {self.cone!r}")
        _check(isinstance(self.ccd_iterations, int) and not isinstance(self.ccd_iterations, bool)
               and self.ccd_iterations >= 1,
               f"Sim.ccd_iterations must be an int >= 1, got {self.ccd_iterations!r}")
        for name in ("iterations", "ls_iterations", "ccd_iterations"):
            _within(f"Sim.{name}", getattr(self, name), 1, 1000)
        _within("Sim.impratio", self.impratio, 0, 1000.0, lo_open=True)
        _within("Sim.sleep_tolerance", self.sleep_tolerance, 0, 1.0, lo_open=True)
        for name, most in (("naconmax", 2**31 - 1), ("njmax", 10**6), ("contacts_per_world", 10**5)):
            if getattr(self, name) is not None:
                _within(f"Sim.{name}", getattr(self, name), 1, most)


@dataclass(frozen=True)
@checked
class Grasp:
    """Top-down parallel-jaw grasp primitive (floating RG2-like gripper)."""

    n_rotations: int = 16
    # The rotations span half a turn (theta = r * pi / n_rotations) instead of a whole one (r * 2 pi
    # / n_rotations), so no index repeats another's grasp turned 180 degrees; net.half_turn must match.
    half_turn: bool = False
    approach_height: float = 0.15  # m above the grasp point
    depth_below_surface: float = 0.03  # m below the surface height at the pixel
    min_height_above_table: float = 0.005  # grasp centre never below this
    lift_height: float = 0.15  # m lifted after closing
    finger_stroke: float = 0.085  # m, full opening between the pads
    grip_force: float = 40.0  # N, actuator force limit
    # Guarded descent: None simulates the whole descent from ``approach_height``; c (m) places the
    # gripper with its fingertips c above the highest object within reach (or the grasp point),
    # skipping the free-space part; the reported travel is still ``approach_height``.  3 cm kept
    # the scripted and heuristic outcomes with 535 instead of 660 steps (bench/RESULTS.md, "Environment
    # throughput", 3rd pass).
    descent_clearance: Optional[float] = 0.03
    # Phase durations, seconds.
    t_settle: float = 0.02  # gripper teleported at rest above the grasp point, fingers opening
    t_descend: float = 0.15  # the simulated descent (0.4 s suits descent_clearance=None)
    t_close: float = 0.3
    t_lift: float = 0.5
    t_post: float = 0.1  # after the lift: gripper parked, dropped / disturbed objects settle (gpu: 0.05)
    # Share of t_lift spent holding still at the top before the grasp is judged; the lift
    # itself (a half-cosine) takes the rest, so its peak acceleration is
    # lift_height * pi^2 / (2 * ((1 - lift_hold) * t_lift)^2).
    lift_hold: float = 0.25
    # Success: object lifted this far above the table, fingers not fully closed.
    success_lift: float = 0.05
    closed_gap: float = 0.005  # pad gap below this counts as "fully closed"

    def __post_init__(self):
        _check(
            self.n_rotations >= 1 and isinstance(self.n_rotations, int),
            f"Grasp.n_rotations must be a positive int, got {self.n_rotations!r}",
        )
        _check(self.finger_stroke > 0, "Grasp.finger_stroke must be > 0")
        for name in ("t_settle", "t_descend", "t_close", "t_lift", "t_post"):
            _check(getattr(self, name) > 0, f"Grasp.{name} must be > 0 seconds")
        _check(0.0 <= self.lift_hold < 1.0, f"Grasp.lift_hold must be in [0, 1), got {self.lift_hold}")
        _within("Grasp.n_rotations", self.n_rotations, 1, 64)
        for name in ("t_settle", "t_descend", "t_close", "t_lift", "t_post"):
            _within(f"Grasp.{name}", getattr(self, name), 0, 10.0, "seconds", lo_open=True)
        _within("Grasp.finger_stroke", self.finger_stroke, 0, 0.5, "metres", lo_open=True)
        _within("Grasp.approach_height", self.approach_height, 0, 1.0, "metres", lo_open=True)
        _within("Grasp.lift_height", self.lift_height, 0, 1.0, "metres", lo_open=True)
        _within("Grasp.depth_below_surface", self.depth_below_surface, 0, 0.2, "metres")
        _within("Grasp.min_height_above_table", self.min_height_above_table, 0, 0.2, "metres")
        _within("Grasp.grip_force", self.grip_force, 0, 1000.0, "N", lo_open=True)
        _within("Grasp.closed_gap", self.closed_gap, 0, self.finger_stroke, "metres (finger_stroke)",
                hi_open=True)
        _check(0 < self.success_lift < self.lift_height,
               f"Grasp.success_lift must be in (0, lift_height = {self.lift_height}) metres: a grasp "
               f"succeeds when the object rises that far, got {self.success_lift}")
        c = self.descent_clearance
        _check(
            c is None or (isinstance(c, (int, float)) and not isinstance(c, bool)
                          and 0.005 <= c <= self.approach_height),
            f"Grasp.descent_clearance must be null/None (simulate the whole descent) or a number "
            f"of metres in [0.005, approach_height = {self.approach_height}], got {c!r}",
        )

    @property
    def rotation_step(self) -> float:
        """Radians between consecutive rotation indices: 2 pi / n_rotations, or pi / n_rotations
        with ``half_turn`` (0 for one rotation)."""
        if self.n_rotations == 1:
            return 0.0
        return (math.pi if self.half_turn else 2.0 * math.pi) / self.n_rotations

    @property
    def n_axes(self) -> int:
        """Distinct closing axes among the rotations: n_rotations / 2 over a full turn (r and
        r + R/2 close along the same line), n_rotations over half a turn."""
        return self.n_rotations if self.half_turn else max(1, self.n_rotations // 2)


@dataclass(frozen=True)
@checked
class DepthNoise:
    """Depth model of a structured-light / active-stereo RGB-D sensor (on by default).

    Applied to every rendered depth image, global and close views alike (``render.add_depth_noise``):

    * steep faces: pixels whose surface is seen at an incidence above ``grazing_dropout_deg``
      (angle between the ray and the surface normal) return no depth;
    * object edges: pixels next to a depth discontinuity larger than ``edge_jump`` (within
      ``edge_width`` pixels of it, either side) return no depth with probability
      ``edge_dropout`` (the projector's shadow and mixed pixels of real sensors);
    * noise: Gaussian, standard deviation ``sigma_base + sigma_quadratic * (z - 0.4)^2`` metres at
      depth z (an axial-noise model fitted to structured-light sensors: about 1.2 mm at
      0.5 m and 1.6 mm at 0.9 m);
    * quantisation: disparity ``fx * baseline / z`` is rounded to steps of
      ``disparity_step`` pixels (about 1.3 mm at 0.6 m with the defaults; 0 = off);
    * ``dropout_prob``: extra missing pixels at random (default 0).
    Missing pixels have depth 0 and leave their heightmap cells at 0, as a real sensor's holes.
    ``enabled = False`` gives the renderer's exact depth (``--set camera.noise.enabled=false``).
    """

    enabled: bool = True
    sigma_base: float = 0.0012  # m
    sigma_quadratic: float = 0.0019  # m per m^2
    grazing_dropout_deg: float = 75.0
    edge_jump: float = 0.01  # m between neighbouring pixels
    edge_width: int = 1  # px on each side of a discontinuity
    edge_dropout: float = 0.5
    disparity_step: float = 0.125  # px (sub-pixel disparity resolution)
    baseline: float = 0.055  # m, projector-to-camera baseline
    dropout_prob: float = 0.0

    def __post_init__(self):
        _within("DepthNoise.sigma_base", self.sigma_base, 0, 0.1, "metres")
        _within("DepthNoise.sigma_quadratic", self.sigma_quadratic, 0, 0.1)
        _within("DepthNoise.grazing_dropout_deg", self.grazing_dropout_deg, 0, 90.0, "degrees", lo_open=True)
        _within("DepthNoise.dropout_prob", self.dropout_prob, 0, 1.0)
        for name in ("edge_jump", "disparity_step"):
            v = getattr(self, name)
            _check(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v >= 0,
                   f"DepthNoise.{name} must be a finite number >= 0, got {v!r}")
        _check(0 < self.grazing_dropout_deg <= 90,
               f"DepthNoise.grazing_dropout_deg must be in (0, 90], got {self.grazing_dropout_deg}")
        _check(isinstance(self.edge_width, int) and not isinstance(self.edge_width, bool)
               and 0 <= self.edge_width <= 8, f"DepthNoise.edge_width must be an int in 0..8, got {self.edge_width!r}")
        _check(0.0 <= self.edge_dropout <= 1.0,
               f"DepthNoise.edge_dropout must be a probability in [0, 1], got {self.edge_dropout}")
        _check(self.baseline > 0, f"DepthNoise.baseline must be > 0 m, got {self.baseline}")


@dataclass(frozen=True)
@checked
class Camera:
    """Pinhole eye-in-hand RGB-D camera."""

    width: int = 640
    height: int = 480
    fx: float = 618.62
    fy: float = 618.62
    cx: Optional[float] = None  # None -> width / 2 (pixel u samples the ray through (u - cx) / fx)
    cy: Optional[float] = None
    near: float = 0.05
    far: float = 2.0
    # Preset global pose: position, and the point it looks at.  From the front of the table
    # and 34 deg off vertical (not straight above the workspace centre, as the eye-in-hand
    # camera of a robot standing at the table edge): the whole workspace, and 12 cm tall
    # objects at its far edge, fall inside the 640 x 480 image (u 55..585, v 38..424), and
    # objects shadow what lies behind them.  The first benchmark used (0, -0.25, 0.60).
    global_position: tuple[float, float, float] = (0.0, -0.42, 0.62)
    global_target: tuple[float, float, float] = (0.0, 0.0, 0.0)
    viewpoint_height: float = 0.25  # m above the surface height at the chosen pixel
    noise: DepthNoise = field(default_factory=DepthNoise)
    renderer: str = "jax"  # "jax": pure-JAX ray caster (any device) | "warp": MJX Warp renderer (GPU)
    render_batch: int = 256  # worlds rendered + projected together (bounds memory; both renderers)
    # Warp renderer only: MuJoCo's back-face culling; off gives the same images, faster (bench/RESULTS.md,
    # "Environment throughput", 8th pass).
    warp_backface_culling: bool = False

    def __post_init__(self):
        _check(
            self.width >= 8 and self.height >= 8,
            f"Camera image must be at least 8 x 8 pixels, got {self.width} x {self.height}",
        )
        _check(self.fx > 0 and self.fy > 0, "Camera.fx and Camera.fy must be > 0")
        _check(0 < self.near < self.far, "Camera needs 0 < near < far")
        _check(self.renderer in ("jax", "warp"), f"Camera.renderer must be 'jax' or 'warp', got {self.renderer!r}")
        _check(self.render_batch >= 1, f"Camera.render_batch must be >= 1, got {self.render_batch}")
        _within("Camera.width", self.width, 8, MAX_IMAGE_SIDE, "pixels")  # first: the bound below needs it
        _within("Camera.height", self.height, 8, MAX_IMAGE_SIDE, "pixels")
        most = (2**31 - 1) // (self.width * self.height)
        _check(self.render_batch <= most,
               f"Camera.render_batch = {self.render_batch} images of {self.width} x {self.height} "
               f"overflow the int32 pixel indices of the heightmap scatter; use at most {most}")
        _within("Camera.fx", self.fx, 0, 1e5, "pixels", lo_open=True)
        _within("Camera.fy", self.fy, 0, 1e5, "pixels", lo_open=True)
        if self.cx is not None:
            _within("Camera.cx", self.cx, 0, self.width, "pixels (0..width)")
        if self.cy is not None:
            _within("Camera.cy", self.cy, 0, self.height, "pixels (0..height)")
        _within("Camera.far", self.far, 0, 100.0, "metres", lo_open=True)
        _within("Camera.viewpoint_height", self.viewpoint_height, self.near, self.far, "metres (near..far)",
                lo_open=True, hi_open=True)
        for name in ("global_position", "global_target"):
            for v in getattr(self, name):
                _within(f"Camera.{name}", v, -10.0, 10.0, "metres")
        _check(math.dist(self.global_position, self.global_target) > 1e-3,
               f"Camera.global_position {self.global_position} and global_target {self.global_target} "
               f"must differ: the camera looks from one at the other")

    @property
    def principal_point(self) -> tuple[float, float]:
        cx = self.width / 2 if self.cx is None else self.cx
        cy = self.height / 2 if self.cy is None else self.cy
        return cx, cy


# ----------------------------------------------------------------------------- learning


@dataclass(frozen=True)
@checked
class Net:
    """Q-network architecture."""

    trunk: str = "densenet121"  # "densenet121" | "small" (fast)
    head_channels: int = 64
    small_width: int = 32  # base width of the "small" trunk
    dtype: str = "float32"  # compute dtype: "float32" | "bfloat16"
    n_rotations: int = 16
    # GDNet's rotations span half a turn (``Grasp.half_turn``, which must match).
    half_turn: bool = False
    # Worlds per Q-network forward when VAGS decides for many worlds (stages 2-3, eval): GDNet's
    # rotations of 512 worlds at once need tens of GB of activations.  0: all worlds at once.
    forward_batch: int = 128
    # Q-network passes only where their result is used, in groups of ``forward_batch`` worlds
    # (``batching.map_in_groups_where``): stage 1's actor on the worlds that take its greedy action
    # (not those that explore or reset), and the grasp after a move (stages 2-3, eval) on the
    # worlds that move.  The actions are the same.  False: every pass over every world.
    forward_needed_only: bool = False
    # ImageNet initialisation of both DenseNet-121 trunks of GDNet (stage 1) and VANet (stage 2):
    # a torchvision DenseNet-121 state dict the user supplies (.pth / .pt, needs torch; or .npz of
    # the same keys, see vags_jax/nets/pretrained.py).  None: random initialisation.
    init: Optional[str] = None

    def __post_init__(self):
        _check(
            self.trunk in ("densenet121", "small"),
            f"Net.trunk must be 'densenet121' or 'small', got {self.trunk!r}",
        )
        if self.init is not None:
            _check(self.trunk == "densenet121",
                   f"Net.init loads ImageNet weights into DenseNet-121 trunks; set net.trunk=densenet121 "
                   f"(now {self.trunk!r}) or drop net.init")
            _check(self.init.lower().endswith((".pth", ".pt", ".npz")),
                   f"Net.init must be a torchvision DenseNet-121 state dict file (.pth / .pt, or .npz of the same "
                   f"keys), got {self.init!r}")
        _check(self.dtype in ("float32", "bfloat16"), f"Net.dtype must be float32 or bfloat16, got {self.dtype!r}")
        _within("Net.head_channels", self.head_channels, 1, 1024)
        _within("Net.small_width", self.small_width, 1, 1024)
        _within("Net.n_rotations", self.n_rotations, 1, 64)
        _within("Net.forward_batch", self.forward_batch, 0, 1 << 20)


@dataclass(frozen=True)
@checked
class DQN:
    gamma: float = 0.5
    huber_delta: float = 1.0
    optimizer: str = "sgd"  # "sgd" (paper) | "adam"
    learning_rate: float = 1e-4
    momentum: float = 0.9
    weight_decay: float = 2e-5
    batch_size: int = 8
    target_update_period: int = 100  # gradient steps between target-network copies
    double_q: bool = False
    symmetric_grasp_label: bool = False  # VPG trick: same label also at rotation (r + R/2) % R

    def __post_init__(self):
        _check(0.0 <= self.gamma < 1.0, f"DQN.gamma must be in [0, 1), got {self.gamma}")
        _check(self.learning_rate > 0, f"DQN.learning_rate must be > 0, got {self.learning_rate}")
        _check(self.optimizer in ("sgd", "adam"), f"DQN.optimizer must be 'sgd' or 'adam', got {self.optimizer!r}")
        _check(self.batch_size >= 1, f"DQN.batch_size must be >= 1, got {self.batch_size}")
        _check(self.target_update_period >= 1, "DQN.target_update_period must be >= 1")
        _within("DQN.learning_rate", self.learning_rate, 0, 1.0, lo_open=True)
        _within("DQN.huber_delta", self.huber_delta, 0, 1e3, lo_open=True)
        _within("DQN.momentum", self.momentum, 0, 1.0, hi_open=True)
        _within("DQN.weight_decay", self.weight_decay, 0, 1.0, hi_open=True)
        _within("DQN.batch_size", self.batch_size, 1, 4096)
        _within("DQN.target_update_period", self.target_update_period, 1, 10**7)


@dataclass(frozen=True)
@checked
class Replay:
    capacity: int = 10_000
    alpha: float = 0.6
    beta: float = 0.4
    priority_eps: float = 1e-3

    def __post_init__(self):
        _check(self.capacity >= 1, f"Replay.capacity must be >= 1, got {self.capacity}")
        _check(0.0 <= self.alpha <= 1.0, f"Replay.alpha must be in [0, 1], got {self.alpha}")
        _check(0.0 <= self.beta <= 1.0, f"Replay.beta must be in [0, 1], got {self.beta}")
        _within("Replay.capacity", self.capacity, 1, 2**31 - 1)
        _within("Replay.priority_eps", self.priority_eps, 0, 1.0, lo_open=True)


@dataclass(frozen=True)
@checked
class Exploration:
    """DAES: epsilon-greedy whose random pixel is drawn among object pixels."""

    daes: bool = True  # False -> random pixel over the whole workspace (ablation)
    eps_start: float = 0.5
    eps_end: float = 0.1
    eps_decay: float = 0.9998  # per grasp attempt (per world), as in VPG
    height_threshold: float = 0.01  # m; a heightmap cell above this contains an object (DAES, eval)

    def __post_init__(self):
        _check(0.0 <= self.eps_end <= self.eps_start <= 1.0,
               f"Exploration needs 0 <= eps_end <= eps_start <= 1, got {self.eps_end}, {self.eps_start}")
        _check(0.0 < self.eps_decay <= 1.0, f"Exploration.eps_decay must be in (0, 1], got {self.eps_decay}")
        _within("Exploration.height_threshold", self.height_threshold, 0, 1.0, "metres", hi_open=True)


STAGE_BOOTSTRAPS = ("target_network", "actor", "actor_argmax")


@dataclass(frozen=True)
@checked
class Stage:
    """One training stage (paper 3.2)."""

    name: str = "gdnet"
    n_worlds: int = 4  # parallel robots
    iterations: int = 100  # env steps (one grasp attempt per world each)
    min_objects: int = 1
    max_objects: int = 5
    max_attempts_extra: int = 5  # round ends after 2 * objects + this many attempts
    updates_per_iteration: int = 1
    learning_starts: int = 16  # transitions in replay before updates start
    # Where the TD target's max Q of the next state comes from: "target_network", a pass of the
    # target network over every sampled next state at each update; "actor" (stage 1 only), the
    # online network's max as the actor computed it when it acted on that state, stored in replay
    # (VPG's stored labels): no pass over next states in the update, and no next states in replay;
    # "actor_argmax" (stage 1 only), the target network's value at the action the actor chose
    # greedily on that state, stored in replay (Double DQN's target with the actor's argmax): the
    # update's target pass covers that one rotation of each next state instead of all.
    bootstrap: str = "target_network"
    # With bootstrap "actor": store each value clipped to [0, 1 / (1 - dqn.gamma)], the range of any
    # discounted return of 0/1 grasp rewards (a barely trained actor's values overshoot it).
    bootstrap_clip: bool = False

    def __post_init__(self):
        _check(self.n_worlds >= 1, f"Stage.n_worlds must be >= 1, got {self.n_worlds}")
        _check(self.bootstrap in STAGE_BOOTSTRAPS,
               f"Stage.bootstrap must be one of {', '.join(map(repr, STAGE_BOOTSTRAPS))}, got {self.bootstrap!r}")
        _check(not self.bootstrap_clip or self.bootstrap == "actor",
               f"Stage.bootstrap_clip clips the values the actor stores; it needs bootstrap='actor', "
               f"got {self.bootstrap!r}")
        _check(self.iterations >= 1, f"Stage.iterations must be >= 1, got {self.iterations}")
        _check(1 <= self.min_objects <= self.max_objects,
               f"Stage needs 1 <= min_objects <= max_objects, got {self.min_objects}..{self.max_objects}")
        _check(bool(self.name.strip()), "Stage.name must not be empty")
        _within("Stage.n_worlds", self.n_worlds, 1, MAX_WORLDS)
        _within("Stage.max_attempts_extra", self.max_attempts_extra, 0, 1000)
        _within("Stage.updates_per_iteration", self.updates_per_iteration, 1, 1024)
        _within("Stage.learning_starts", self.learning_starts, 0, 2**31 - 1)
        _check(self.n_worlds * self.iterations < 2**31,
               f"Stage: n_worlds * iterations = {self.n_worlds * self.iterations:,} grasp attempts "
               f"overflow the int32 attempt counter; keep it below 2**31 (lower iterations)")


VAGS_LOCAL_PLANNERS = ("gdnet", "ggcnn")
VAGS_GATES = ("success", "q", "rate")
VAGS_VIEW_REWARDS = ("success", "eq5")
VAGS_VIEW_ESTIMATES = ("mean", "vanet")
VAGS_VIEWPOINTS = ("vanet", "grasp")
VAGS_STAGE3_GDNET = ("all", "direct", "frozen")
VAGS_STAGE3_GDNET_PICKS = ("rate", "last")
VAGS_CLOSE_REGIONS = ("seen", "map")
VAGS_GATE_ESTIMATES = ("grasp", "symmetric", "window")
VAGS_CLOSE_SCORES = ("q", "success")
VAGS_DIRECT_SCORES = ("q", "q_mean", "success")
VAGS_SUCCESS_LABELS = ("grasp", "clean")


@dataclass(frozen=True)
@checked
class Vags:
    """VAGS's decision, its close-view grasp and VANet's reward (stages 2 and 3; ``eval.py
    --policy vags``).  docs/method.md explains each choice; the paper's rules are the options
    ``local_planner="ggcnn"``, ``gate="q"``, ``view_reward="eq5"``, ``vanet_gamma=0.5``.

    local_planner: the grasp after a camera move.  "gdnet": the close depth image is projected
      into the global heightmap (``view_fusion``) and the argmax among the cells the close view
      saw is grasped (of GDNet's Q or the success net's estimate: ``close_score``); "ggcnn":
      GG-CNN's best grasp in the close image (the paper).
    gate: when to move.  "success": move when VANet's estimate of the success after a move
      exceeds the success net's estimate of GDNet's direct grasp by more than ``move_cost``
      (both nets are trained with gamma 0 on 0/1 rewards, so both estimate a probability);
      "q": move when GDNet's largest Q is at most the threshold (the paper's rule); "rate": move
      where a move raises the picks per hour, by a table measured on the trained run (by
      train.py after stage 3, ``gate_table``; or ``python -m vags_jax.stages.gate_measure --run
      RUN``); stage 3 of such a run trains with "success".  The ``gpu`` presets' default.
    threshold / threshold_quantile: the "q" gate's threshold; None calibrates it (the quantile
      of the frozen GDNet's largest Q over stage 2's first views), and again at stage 3's end
      over its last views (GDNet changed).  Stage 2 always gates with "q" (VANet and the
      success net are still learning).
    move_cost: estimated success a move must add ("success" gate).
    view_estimate: the "success" gate's estimate of the success after a move.  "mean": the
      running mean of that success over stages 2-3's greedy moves, one number for every state
      (VANet's largest value did not rank that success: bench/RESULTS.md, "Viewpoints that
      pay"); "vanet": VANet's largest Q on the state, less its running bias.
    viewpoint: where the camera moves.  "vanet": above VANet's argmax cell (the paper); "grasp":
      above GDNet's argmax cell on the global view, a close look at the grasp it would make
      (VANet then only learns from those moves).
    calibration_decay: per-iteration decay of the running means of the "success" gate: the bias
      of each estimate (estimate - outcome over stages 2-3's greedy attempts, subtracted before
      comparing; VANet's largest value over the map is biased upwards) and the success after a
      move ("mean" view estimate).
    view_reward: VANet's reward.  "success": 1 when the grasp after the move succeeds, else 0;
      "eq5": paper eq. 5 as reconstructed: ``success_reward`` on success plus ``view_bonus``
      when GDNet's largest Q on the next global view exceeds the one before the move.
    vanet_gamma: VANet's discount (0: its Q estimates the success of the grasp after the move).
    stage3_gdnet: what GDNet learns from in stage 3.  "all": its global-view grasps and, with
      the "gdnet" planner, its grasps on the fused close-view maps (so the grasp after a move
      improves too); "direct": its global-view grasps only (as in the paper, whose GDNet never
      grasps after a move); "frozen": GDNet keeps stage 1's weights and explores no grasps
      (stage 3 trains VANet and the success net).  Why "all": bench/RESULTS.md, "Viewpoints
      that pay, thirteenth look"; runs written before this field read "all" (``LEGACY_FIELDS``).
    stage3_gdnet_pick: which GDNets the trained run keeps.  "rate": when train.py measures the
      rate gate's table after stage 3 (``gate_table.worlds`` > 0), it measures it with stage 3's
      GDNet, with the GDNet stage 3 started from (stage 2's), and (with the "gdnet" planner)
      with stage 2's for the direct grasps and stage 3's, which learned on the fused maps, for
      the grasps after a move ("split"); it keeps the GDNets under which VAGS picks most per
      second (the "q" threshold comes with the direct grasps' GDNet; RUN/gate.json records every
      candidate); stage 3's GDNet alone varied from 13 points worse to 4 better across
      trainings.  "last": stage 3's GDNet, always.  Runs written before this field read "last".
    close_region: where the "gdnet" planner grasps after a move.  "seen": GDNet's argmax among
      the cells the close view saw (anywhere if it saw none); "map": its argmax anywhere on the
      fused maps, so a move can only add grasps (bench/RESULTS.md, "sixteenth look": worse on the
      sixth run, 86.0-87.8 % against 88.0-88.7 % with "seen").
    gate_estimate: the success net's estimate of GDNet's grasp that the "success" and "rate"
      gates read at evaluation (``decision.success_estimate``; stage 3's training gate reads
      "grasp").  "grasp": its value at the grasp; "symmetric": the mean with the value at the
      same grasp turned half a turn; "window": the mean over both rotations and the 3 x 3 cells
      around the grasp.  The rate gate's table is fit on this estimate and records it
      (RUN/gate.json "estimate"); a run is evaluated with the estimate its table was fit on.
    close_score: what the "gdnet" planner maximizes among its cells after a move.  "q": GDNet's
      Q (gamma 0.5: immediate success plus discounted future reward); "success": the success
      net's estimate (gamma 0: the grasp's own success), averaged over the grasp and the same
      grasp turned half a turn (``decision.half_turn_mean``).  Read where a trained VAGS run is
      used (eval.py, the rate gate's table, predict); training scores by
      ``train_close_score``.  The table records it (RUN/gate.json "close_score"), and a run is
      evaluated with the setting its table was measured with.
    direct_score: what plans the direct grasp from the global view.  "q": GDNet's argmax (the
      paper); "q_mean": the argmax of GDNet's half-turn mean (each parallel-jaw grasp's two
      rotations, r and r + R/2, averaged: two views of one grasp); "success": the argmax of
      the success net's half-turn mean over the global maps, the score the "gdnet" planner
      maximizes after a move under ``close_score="success"`` (so ``--no-viewpoint`` then
      measures the same planner without the move).  Read where a
      trained run is used (eval.py, the rate gate's table, predict); training plans GDNet's
      argmax.  The table records it (RUN/gate.json "direct_score"), and a run is evaluated with
      the setting its table was measured with.
    train_close_score: ``close_score`` for the grasps after a move in training (stages 2-3):
      "success" makes VANet's reward and the running success after a move follow the grasp
      the evaluation makes under ``close_score="success"``; "q": GDNet's Q.  The NBV baseline
      always scores by "q" (it trains no success net).
    max_motion_number: a cap on the "rate" gate's moves (0: none).  The gate moves in the bins
      of its table where a move raises the picks per hour; with a cap it drops moving bins,
      the smallest success gain first, until the motion number its table predicts (motions per
      grasped object on the table's states) is at most the cap.  The table's prediction ran
      0.028 below the benchmark's on average (twenty-seventh look), and 0.055 (0.012-0.097)
      since the benchmark drops spilled piles again (five trainings; bench/RESULTS.md,
      "forty-second and forty-third looks").  Read when the table is loaded
      (eval.py, predict): ``--set`` it on any run.
    gate_min_z: the "rate" gate moves only in the bins where its table shows a move to pay: a
      bin whose move value is positive but within ``gate_min_z`` standard errors of 0 (over the
      bin's states, RUN/gate.json "move_value_se") grasps directly (``rate_gate.significant``;
      applied before ``max_motion_number``).  0 (default): every bin of positive value moves, as
      before this field.  Whether such a bin moves is otherwise the sign of a number within the
      table's noise, and it decides whether a training meets the motion goals or the margin
      (bench/RESULTS.md, "Viewpoints that pay", thirty-fourth and forty-first looks).  Read when
      the table is loaded (eval.py, predict): ``--set`` it on any run whose table records the
      errors.
    cap_split: under ``max_motion_number``, take the moving bins by success gain and split the
      next one, its lowest-p_direct states moving as far as the cap allows
      (``rate_gate.split_capped``), from the states the table was measured on
      (RUN/gate_states.npz); False, or a run without those states: drop whole bins, as before
      this field.  Read when the table is loaded.
    success_label: what the success net (gamma 0, stages 2-3) learns to estimate.  "grasp": the
      grasp succeeded (GDNet's reward); "clean": the grasp succeeded and no object left the
      table during the attempt (``VagsEnv.knocked_off``), so the grasp after a move, scored by
      it under ``close_score="success"``, avoids grasps that knock objects off, and the
      "success" gate's running estimates (its bias and the mean after a move) follow the same
      label.  GDNet's reward and VANet's stay the grasp's success.  Runs written before this
      field read "grasp".
    train_ggcnn: the pipeline (train.py with no --stage) also trains GG-CNN when local_planner
      is "gdnet", which does not use it (for eval.py --policy ggcnn / ggcnn-close); with "ggcnn"
      it always does.  ``train.py --stage ggcnn --out RUN`` adds one to a run later.
    GDNet's reward (eq. 3) is ``success_reward`` on success, else 0.
    """

    local_planner: str = "gdnet"
    gate: str = "success"
    threshold: Optional[float] = None
    threshold_quantile: float = 0.5
    move_cost: float = 0.05
    view_estimate: str = "mean"
    viewpoint: str = "vanet"
    calibration_decay: float = 0.9
    view_reward: str = "success"
    vanet_gamma: float = 0.0
    success_reward: float = 1.0
    view_bonus: float = 1.0
    stage3_gdnet: str = "all"
    stage3_gdnet_pick: str = "rate"
    close_region: str = "seen"
    max_motion_number: float = 0.0
    gate_min_z: float = 0.0
    cap_split: bool = True
    train_ggcnn: bool = False
    gate_estimate: str = "grasp"
    close_score: str = "q"
    train_close_score: str = "q"
    direct_score: str = "q"
    success_label: str = "grasp"

    def __post_init__(self):
        _check(self.local_planner in VAGS_LOCAL_PLANNERS,
               f"Vags.local_planner must be one of {VAGS_LOCAL_PLANNERS}, got {self.local_planner!r}")
        _check(self.gate in VAGS_GATES, f"Vags.gate must be one of {VAGS_GATES}, got {self.gate!r}")
        _check(self.view_estimate in VAGS_VIEW_ESTIMATES,
               f"Vags.view_estimate must be one of {VAGS_VIEW_ESTIMATES}, got {self.view_estimate!r}")
        _check(self.viewpoint in VAGS_VIEWPOINTS,
               f"Vags.viewpoint must be one of {VAGS_VIEWPOINTS}, got {self.viewpoint!r}")
        _check(self.stage3_gdnet in VAGS_STAGE3_GDNET,
               f"Vags.stage3_gdnet must be one of {VAGS_STAGE3_GDNET}, got {self.stage3_gdnet!r}")
        _check(self.stage3_gdnet_pick in VAGS_STAGE3_GDNET_PICKS,
               f"Vags.stage3_gdnet_pick must be one of {VAGS_STAGE3_GDNET_PICKS}, got {self.stage3_gdnet_pick!r}")
        _check(self.close_region in VAGS_CLOSE_REGIONS,
               f"Vags.close_region must be one of {VAGS_CLOSE_REGIONS}, got {self.close_region!r}")
        _check(self.gate_estimate in VAGS_GATE_ESTIMATES,
               f"Vags.gate_estimate must be one of {VAGS_GATE_ESTIMATES}, got {self.gate_estimate!r}")
        for name in ("close_score", "train_close_score"):
            value = getattr(self, name)
            _check(value in VAGS_CLOSE_SCORES, f"Vags.{name} must be one of {VAGS_CLOSE_SCORES}, got {value!r}")
            _check(value == "q" or self.local_planner == "gdnet",
                   f"Vags.{name}={value!r} scores the 'gdnet' close-view planner's cells, and local_planner is "
                   f"{self.local_planner!r}: set vags.{name}=q or vags.local_planner=gdnet")
        _check(self.direct_score in VAGS_DIRECT_SCORES,
               f"Vags.direct_score must be one of {VAGS_DIRECT_SCORES}, got {self.direct_score!r}")
        _check(self.success_label in VAGS_SUCCESS_LABELS,
               f"Vags.success_label must be one of {VAGS_SUCCESS_LABELS}, got {self.success_label!r}")
        _check(self.view_reward in VAGS_VIEW_REWARDS,
               f"Vags.view_reward must be one of {VAGS_VIEW_REWARDS}, got {self.view_reward!r}")
        if self.threshold is not None:
            _within("Vags.threshold", self.threshold, -1e6, 1e6)
        _within("Vags.threshold_quantile", self.threshold_quantile, 0.0, 1.0)
        _within("Vags.move_cost", self.move_cost, -1.0, 1.0)
        _within("Vags.calibration_decay", self.calibration_decay, 0.0, 1.0, hi_open=True)
        _within("Vags.vanet_gamma", self.vanet_gamma, 0.0, 1.0, hi_open=True)
        _within("Vags.success_reward", self.success_reward, 0.0, 1e3, lo_open=True)
        _within("Vags.view_bonus", self.view_bonus, 0.0, 1e3)
        _check(self.max_motion_number == 0.0 or 1.0 <= self.max_motion_number <= 10.0,
               f"Vags.max_motion_number must be 0 (no cap) or within [1, 10] (a grasp is one motion, a move "
               f"and a grasp two), got {self.max_motion_number}")
        _within("Vags.gate_min_z", self.gate_min_z, 0.0, 10.0, unit="standard errors")


# ----------------------------------------------------------------------------- GG-CNN

GGCNN_SIZE_MULTIPLE = 12  # GG-CNN input H, W must be multiples of this (vags_jax.nets.ggcnn)
GGCNN_ROTATIONS = ("quarter", "any", "none")
GGCNN_LABELS = ("success_ratio", "positives")  # GGCNNConfig.labels (vags_jax.ggcnn.labels)


@dataclass(frozen=True)
@checked
class GGCNNConfig:
    """GG-CNN input, post-processing and training settings (``Config.ggcnn``).

    The defaults are GG-CNN's (300 x 300 input, quality smoothing sigma 2, width / 150, Adam
    at lr 1e-3, batch 8, zoom 0.5-1 and quarter-turn rotations) except two.  The angle and
    width are read unsmoothed at the quality peak (sigmas 0; GG-CNN's 2 and 1 mix neighbouring
    grasps' angles into the peak's, so decoding a label map missed grasps it held).  Labels are
    ``"success_ratio"``: every tried candidate counts, failures included, and untried pixels
    weigh ``untried_weight`` in the loss; ``"positives"`` is GG-CNN's rule (successes only,
    every pixel weight 1), see ``vags_jax.ggcnn.labels``.
    ``train_steps`` Adam updates make ``train.py --stage ggcnn`` (GG-CNN trained for ~50 epochs of
    Cornell's ~900 images at batch 8, ~5,600 updates; our default is of the same order).
    """

    input_size: int = 300  # network input side in pixels (a multiple of 12)
    # Side (camera pixels) of the centred square cropped from the camera depth image before it
    # is resized to `input_size`.  None: the largest centred square, min(height, width).
    crop_size: Optional[int] = None
    inpaint_iters: int = 64  # neighbour-fill passes; holes wider than ~2x this get the frame mean
    quality_sigma: float = 2.0  # Gaussian smoothing of the quality map (pixels)
    angle_sigma: float = 0.0  # ... of the cos 2theta / sin 2theta maps (GG-CNN: 2)
    width_sigma: float = 0.0  # ... of the width map (GG-CNN: 1)
    width_scale: float = 150.0  # width map = opening in input pixels / width_scale
    learning_rate: float = 1e-3
    batch_size: int = 8
    zoom_range: tuple[float, float] = (0.5, 1.0)  # augmentation: crop side fraction, resized up
    rotation: str = "quarter"  # augmentation: "quarter" (0/90/180/270 deg), "any", "none"
    train_steps: int = 4000  # Adam updates of train.py --stage ggcnn
    # Training labels: "positives" (GG-CNN's rule) or "success_ratio" (failures count); the latter
    # held out worse on the H100 (bench/RESULTS.md, "Viewpoints that pay").
    labels: str = "positives"
    untried_weight: float = 0.1  # "success_ratio": loss weight of pixels no candidate covers

    def __post_init__(self):
        m = GGCNN_SIZE_MULTIPLE
        _check(self.input_size >= m and self.input_size % m == 0,
               f"GGCNNConfig.input_size must be a positive multiple of {m} (e.g. 300), got {self.input_size!r}")
        _within("GGCNNConfig.input_size", self.input_size, m, MAX_IMAGE_SIDE, "pixels")
        _check(self.crop_size is None or self.crop_size >= 1,
               f"GGCNNConfig.crop_size must be None or an int >= 1 camera pixels, got {self.crop_size!r}")
        if self.crop_size is not None:
            _within("GGCNNConfig.crop_size", self.crop_size, 1, MAX_IMAGE_SIDE, "camera pixels")
        _within("GGCNNConfig.inpaint_iters", self.inpaint_iters, 0, 4096)
        for name in ("quality_sigma", "angle_sigma", "width_sigma"):
            _within(f"GGCNNConfig.{name}", getattr(self, name), 0, 100.0, "pixels")
        _within("GGCNNConfig.width_scale", self.width_scale, 0, 1e4, lo_open=True)
        _within("GGCNNConfig.learning_rate", self.learning_rate, 0, 1.0, lo_open=True)
        _within("GGCNNConfig.batch_size", self.batch_size, 1, 1 << 16)
        _within("GGCNNConfig.train_steps", self.train_steps, 1, 10**8)
        lo, hi = self.zoom_range
        _check(0 < lo <= hi <= 1,
               f"GGCNNConfig.zoom_range must satisfy 0 < low <= high <= 1, got {self.zoom_range}")
        _check(self.rotation in GGCNN_ROTATIONS,
               f"GGCNNConfig.rotation must be one of {GGCNN_ROTATIONS}, got {self.rotation!r}")
        _check(self.labels in GGCNN_LABELS,
               f"GGCNNConfig.labels must be one of {GGCNN_LABELS}, got {self.labels!r}")
        _within("GGCNNConfig.untried_weight", self.untried_weight, 0, 1.0)


@dataclass(frozen=True)
@checked
class GGCNNData:
    """GG-CNN's training views, labelled in physics (``Config.ggcnn_data``; ``vags_jax.ggcnn.data``).

    Each view is a depth image of a fresh random scene of ``min_objects..max_objects`` objects
    (the config's scenes): a close view (``Camera.viewpoint_height`` above a random object
    cell, shifted by up to ``view_jitter``) or, with probability ``global_view_share``, the
    global view.  ``candidates`` grasps per view (centres on object pixels of the view, angles
    uniform) are tried in parallel copies of the scene and become label rectangles
    (centre-third rule; ``GGCNNConfig.labels`` says how failures count) of length = the
    measured jaw gap + ``width_margin`` (failures: the full stroke) and across-size ``jaw``.  ``scenes_per_batch * candidates`` worlds run together.
    """

    views: int = 2048  # training views
    heldout_views: int = 256  # views of other scenes, for held-out accuracy
    candidates: int = 64  # grasps tried per view
    scenes_per_batch: int = 16
    min_objects: int = 1
    max_objects: Optional[int] = None  # None: scene.max_objects
    global_view_share: float = 0.25
    view_jitter: float = 0.04  # m, xy offset of a close view from the chosen object cell
    jaw: float = 0.02  # m, label rectangle extent across the closing axis (finger pad width)
    width_margin: float = 0.01  # m added to the measured jaw gap for the width label

    def __post_init__(self):
        _within("GGCNNData.views", self.views, 1, 1 << 22)
        _within("GGCNNData.heldout_views", self.heldout_views, 1, 1 << 22)
        _within("GGCNNData.candidates", self.candidates, 1, 4096)
        _within("GGCNNData.scenes_per_batch", self.scenes_per_batch, 1, MAX_WORLDS)
        _check(self.scenes_per_batch * self.candidates <= MAX_WORLDS,
               f"GGCNNData: scenes_per_batch * candidates = {self.scenes_per_batch * self.candidates:,} "
               f"worlds, more than {MAX_WORLDS:,}; lower one of them")
        _within("GGCNNData.min_objects", self.min_objects, 1, 1000)
        _check(self.max_objects is None or self.min_objects <= self.max_objects,
               f"GGCNNData needs 1 <= min_objects <= max_objects, got {self.min_objects}..{self.max_objects}")
        _within("GGCNNData.global_view_share", self.global_view_share, 0, 1.0)
        _within("GGCNNData.view_jitter", self.view_jitter, 0, 0.5, "metres")
        _within("GGCNNData.jaw", self.jaw, 0, 0.2, "metres", lo_open=True)
        _within("GGCNNData.width_margin", self.width_margin, 0, 0.2, "metres")


# ----------------------------------------------------------------------------- baselines


@dataclass(frozen=True)
@checked
class Mvp:
    """Multi-View Picking (Morrison et al. 2019; ``eval.py --policy mvp``, docs/baselines.md).

    A grid of ``cell``-sized cells over the workspace keeps, per cell, a histogram of GG-CNN's
    quality in ``quality_bins`` bins and the quality-weighted votes of ``angle_bins`` grasp
    angles, updated from every view.  After the global view the camera moves straight above the
    workspace centre at ``start_height`` (m above the table) looking down, then ``step`` m per
    view: towards the cell of largest information gain (the footprint-blurred entropy of the
    quality histograms) less the distance cost to the best grasp (``best_scale``,
    ``best_gain``, weighted by the camera's height), within ``greedy_window`` m, and always
    down (at least ``min_descent`` of each step).  Viewing stops before the camera would go
    below ``stop_height``; the best fused grasp is executed.  Failed grasps leave a Gaussian of
    ``failure_sigma`` m (height 1) in a failure map subtracted from the quality for the rest of
    the round.  The MVP code's values: 5 mm cells, 10 x 18 bins, 0.15 m, 0.75, 0.1 m, 7.5 mm.
    """

    cell: float = 0.005
    quality_bins: int = 10
    angle_bins: int = 18
    start_height: float = 0.50
    stop_height: float = 0.25
    step: float = 0.05
    min_descent: float = 0.6
    greedy_window: float = 0.10
    best_scale: float = 0.15
    best_gain: float = 0.75
    failure_sigma: float = 0.0075

    def __post_init__(self):
        _within("Mvp.cell", self.cell, 0.001, 0.1, "metres")
        _within("Mvp.quality_bins", self.quality_bins, 2, 100)
        _within("Mvp.angle_bins", self.angle_bins, 2, 180)
        _within("Mvp.stop_height", self.stop_height, 0.0, 2.0, "metres", lo_open=True)
        _check(self.stop_height < self.start_height <= 2.0,
               f"Mvp needs stop_height < start_height <= 2 m, got {self.stop_height} and {self.start_height}")
        _within("Mvp.step", self.step, 0.0, 1.0, "metres", lo_open=True)
        _within("Mvp.min_descent", self.min_descent, 0.0, 1.0, lo_open=True)
        _check((self.start_height - self.stop_height) / (self.step * self.min_descent) <= 200,
               "Mvp: (start_height - stop_height) / (step * min_descent) must be at most 200 view steps")
        _within("Mvp.greedy_window", self.greedy_window, 0.0, 1.0, "metres", lo_open=True)
        _within("Mvp.best_scale", self.best_scale, 0.0, 10.0, "metres", lo_open=True)
        _within("Mvp.best_gain", self.best_gain, 0.0, 100.0)
        _within("Mvp.failure_sigma", self.failure_sigma, 0.0, 0.1, "metres")

    def view_steps(self) -> int:
        """The most camera moves of one attempt: the move to the start pose, then one per view
        step while each step descends at least ``step * min_descent``."""
        return 1 + int(math.floor((self.start_height - self.stop_height) / (self.step * self.min_descent) + 1e-9))


# ----------------------------------------------------------------------------- benchmark


@dataclass(frozen=True)
@checked
class Push:
    """VPG's push primitive (``vags_jax.sim.push``): the closed gripper is lowered beside the
    chosen heightmap cell, moved ``length`` straight along the push direction, then lifted.

    The fingertips go ``clearance`` above the surface height at the cell (VPG pushes at the
    cell's height); the direction of rotation index r is ``r * 2 pi / n_rotations`` (all 16
    directions differ, unlike grasps).  Phases (seconds): ``t_settle`` at rest, ``t_descend``
    down from the guarded start (``grasp.descent_clearance`` above what is within reach),
    ``t_push`` along the line, ``t_lift`` up by ``lift_height``; then the gripper is parked and
    the scene settles ``grasp.t_post``."""

    length: float = 0.10  # m, VPG's 10 cm
    clearance: float = 0.01  # m, fingertips above the surface height at the cell
    lift_height: float = 0.10
    t_settle: float = 0.02
    t_descend: float = 0.15
    t_push: float = 0.5
    t_lift: float = 0.2

    def __post_init__(self):
        _within("Push.length", self.length, 0, 0.5, "metres", lo_open=True)
        _within("Push.clearance", self.clearance, 0, 0.1, "metres")
        _within("Push.lift_height", self.lift_height, 0, 1.0, "metres", lo_open=True)
        for name in ("t_settle", "t_descend", "t_push", "t_lift"):
            _within(f"Push.{name}", getattr(self, name), 0, 10.0, "seconds", lo_open=True)


@dataclass(frozen=True)
@checked
class Vpg(Stage):
    """VPG's training stage (``train.py --stage vpg``, ``vags_jax.stages.vpg``): its budget as
    a ``Stage`` (one push or grasp per world per iteration; a round ends when the table is
    clear or after ``2 * objects + max_attempts_extra`` actions) and VPG's rewards: a
    successful grasp ``grasp_reward``, a push that changed the scene ``push_reward``.  A change
    is more than ``change_cells`` heightmap cells whose height changed by more than
    ``change_min`` and less than ``change_max`` metres (VPG: 300 of 224 x 224 cells, 0.01 m,
    0.3 m).  The learner settings are the ``dqn`` section's (gamma 0.5 as VPG)."""

    name: str = "vpg"
    max_objects: int = 10
    grasp_reward: float = 1.0
    push_reward: float = 0.5
    change_cells: int = 300
    change_min: float = 0.01
    change_max: float = 0.3

    def __post_init__(self):
        Stage.__post_init__(self)
        _within("Vpg.grasp_reward", self.grasp_reward, 0, 100.0)
        _within("Vpg.push_reward", self.push_reward, 0, 100.0)
        _within("Vpg.change_cells", self.change_cells, 0, MAX_HEIGHTMAP_PX**2)
        _check(0 <= self.change_min < self.change_max,
               f"Vpg.change_min must be in [0, change_max = {self.change_max}) metres, got {self.change_min}")


# Drops again for a spilled pile unless benchmark.redrop_spilled says otherwise: on the gpu preset's
# piles of 6-10 objects 10 left 0.1-0.4 % of rounds spilled, against a third without (bench/RESULTS.md).
DEFAULT_REDROPS = 10


@dataclass(frozen=True)
@checked
class Benchmark:
    """The benchmark protocol (``eval.py``, ``vags_jax.benchmark.protocol``; docs/benchmark.md).

    ``rounds`` rounds (parallel worlds) for each group size in ``groups``; a round ends when
    the table is clear or after ``2 * objects + max_attempts_extra`` attempts.  The robot-time
    model of picks per hour (``evaluate.MotionTimeModel``): every commanded Cartesian move at
    ``speed``, ``capture_s`` per motion (an RGB-D capture + inference at each pose reached),
    ``close_s`` + ``lift_s`` per attempt, ``place_s`` per success.  Round numbers for a UR5 +
    RG2 cell, the same for every method; not measured on a robot.
    ``redrop_spilled``: a round whose pile drop left an object off the table (before any
    attempt) gets those objects dropped onto its pile again, up to this many times, keeping the
    round's draws, so that a round of k objects starts with k objects in the workspace, as the
    paper's do ("pile" placement).  None (the default): ``DEFAULT_REDROPS`` on "pile" scenes
    when ``redraw_spilled`` is 0, else 0 (``spilled_remedy``).  ``redraw_spilled``: the same by
    drawing the round's scene again, up to this many times (0: never); at most one of the two
    may be above 0.
    """

    groups: Optional[tuple[int, ...]] = None  # None: 1..scene.max_objects
    rounds: int = 50
    max_attempts_extra: int = 5
    redraw_spilled: int = 0
    redrop_spilled: Optional[int] = None
    speed: float = 0.5  # m/s
    capture_s: float = 0.5
    close_s: float = 0.5
    lift_s: float = 0.5
    place_s: float = 2.0

    def __post_init__(self):
        if self.groups is not None:
            _check(len(self.groups) >= 1, "Benchmark.groups must name at least one object count, e.g. [1, 2, 3]")
            for k in self.groups:
                _within("Benchmark.groups", k, 1, 1000, "objects")
            _check(len(set(self.groups)) == len(self.groups), f"Benchmark.groups must not repeat, got {self.groups}")
        _within("Benchmark.rounds", self.rounds, 1, MAX_WORLDS)
        _within("Benchmark.max_attempts_extra", self.max_attempts_extra, 0, 1000)
        _check(isinstance(self.redraw_spilled, int) and not isinstance(self.redraw_spilled, bool)
               and 0 <= self.redraw_spilled <= 100,
               f"Benchmark.redraw_spilled must be a whole number of redraws in 0..100, got {self.redraw_spilled!r}")
        _check(self.redrop_spilled is None or (isinstance(self.redrop_spilled, int)
                                                and not isinstance(self.redrop_spilled, bool)
                                                and 0 <= self.redrop_spilled <= 100),
               f"Benchmark.redrop_spilled must be a whole number of drops in 0..100 (or null: {DEFAULT_REDROPS} "
               f"on pile scenes), got {self.redrop_spilled!r}")
        _check(not (self.redraw_spilled and self.redrop_spilled),
               f"Benchmark.redraw_spilled = {self.redraw_spilled} and Benchmark.redrop_spilled = "
               f"{self.redrop_spilled} are two remedies for the same spill: set at most one of them above 0 "
               f"(e.g. --set benchmark.redrop_spilled=0 benchmark.redraw_spilled={self.redraw_spilled})")
        _within("Benchmark.speed", self.speed, 0, 100.0, "m/s", lo_open=True)
        for name in ("capture_s", "close_s", "lift_s", "place_s"):
            _within(f"Benchmark.{name}", getattr(self, name), 0, 3600.0, "seconds")


@dataclass(frozen=True)
@checked
class GateTable:
    """The "rate" gate's table (``vags.gate="rate"``; ``vags_jax.stages.gate_measure``), measured
    by ``train.py`` at the end of the pipeline into RUN/gate.json: ``worlds`` fresh piles of
    stage 3's object counts, ``steps`` direct attempts each (every state runs both branches),
    ``bins`` quantile bins of the success net's p_direct, piles drawn from ``seed``.
    ``worlds=0``: the pipeline measures no table (``python -m vags_jax.stages.gate_measure``
    can later).  ``count_lost``: each object a branch knocks off the table counts as a pick
    lost (the gate then maximises net picks per second; ``rate_gate``)."""

    worlds: int = 256
    steps: int = 4
    bins: int = 8
    seed: int = 0
    count_lost: bool = False

    def __post_init__(self):
        _within("GateTable.worlds", self.worlds, 0, 1 << 20)
        _within("GateTable.steps", self.steps, 1, 1000)
        _within("GateTable.bins", self.bins, 1, 1000)


@dataclass(frozen=True)
@checked
class Parallel:
    """Data-parallel training over local devices (``train.py --devices``;
    ``vags_jax.stages.data_parallel``): stage 1's worlds, replay and batch are split evenly over
    ``devices`` devices, gradients and BatchNorm statistics averaged.  1: one device, as before."""

    devices: int = 1

    def __post_init__(self):
        _within("Parallel.devices", self.devices, 1, 4096)


@dataclass(frozen=True)
@checked
class Config:
    """Everything, for one run."""

    seed: int = 0
    workspace: Workspace = field(default_factory=Workspace)
    scene: Scene = field(default_factory=Scene)
    sim: Sim = field(default_factory=Sim)
    grasp: Grasp = field(default_factory=Grasp)
    camera: Camera = field(default_factory=Camera)
    net: Net = field(default_factory=Net)
    dqn: DQN = field(default_factory=DQN)
    replay: Replay = field(default_factory=Replay)
    exploration: Exploration = field(default_factory=Exploration)
    stage1: Stage = field(default_factory=Stage)
    # Stage 2: VANet with GDNet frozen; stage 3: both, updated alternately (paper 3.2).
    stage2: Stage = field(default_factory=lambda: Stage(name="vanet", min_objects=1, max_objects=10))
    stage3: Stage = field(default_factory=lambda: Stage(name="alternate", min_objects=1, max_objects=10))
    # The NBV baseline (train.py --stage nbv): a small viewpoint network trained as VANet in stage 2,
    # but always moving.  Its max_objects is capped at scene.max_objects when the worlds are drawn.
    nbv: Stage = field(default_factory=lambda: Stage(name="nbv", min_objects=1, max_objects=10))
    vags: Vags = field(default_factory=Vags)
    ggcnn: GGCNNConfig = field(default_factory=GGCNNConfig)
    ggcnn_data: GGCNNData = field(default_factory=GGCNNData)
    benchmark: Benchmark = field(default_factory=Benchmark)
    mvp: Mvp = field(default_factory=Mvp)
    # VPG, the push-and-grasp baseline (train.py --stage vpg): its stage and its push primitive.
    vpg: Vpg = field(default_factory=Vpg)
    push: Push = field(default_factory=Push)
    parallel: Parallel = field(default_factory=Parallel)
    gate_table: GateTable = field(default_factory=GateTable)

    def __post_init__(self):
        N = self.scene.max_objects
        _check(self.ggcnn_data.max_objects is None or self.ggcnn_data.max_objects <= N,
               f"ggcnn_data.max_objects ({self.ggcnn_data.max_objects}) exceeds scene.max_objects ({N})")
        _check(self.ggcnn_data.min_objects <= N,
               f"ggcnn_data.min_objects ({self.ggcnn_data.min_objects}) exceeds scene.max_objects ({N})")
        _check(self.benchmark.groups is None or max(self.benchmark.groups) <= N,
               f"benchmark.groups {self.benchmark.groups} go above scene.max_objects ({N}); the scene "
               f"holds at most {N} objects")
        # (vpg's objects and learning_starts are checked when it trains: check_vpg_fits.)
        for name in ("stage1", "stage2", "stage3", "nbv"):
            st = getattr(self, name)
            _check(st.max_objects <= self.scene.max_objects or name == "nbv",  # nbv: capped when drawn
                   f"{name}.max_objects ({st.max_objects}) exceeds scene.max_objects ({self.scene.max_objects})")
            _check(st.learning_starts <= self.replay.capacity,
                   f"{name}.learning_starts ({st.learning_starts}) exceeds replay.capacity "
                   f"({self.replay.capacity}): learning would never start")
        _check(self.net.n_rotations == self.grasp.n_rotations,
               "net.n_rotations must equal grasp.n_rotations")
        _check(self.net.half_turn == self.grasp.half_turn,
               f"net.half_turn ({self.net.half_turn}) must equal grasp.half_turn ({self.grasp.half_turn}): "
               f"set both, e.g. --set grasp.half_turn=true net.half_turn=true")
        _check(not (self.grasp.half_turn and self.dqn.symmetric_grasp_label),
               "dqn.symmetric_grasp_label also trains rotation (r + R/2) % R, the same grasp turned half a "
               "turn, which half-turn rotations (grasp.half_turn) do not have: set dqn.symmetric_grasp_label=false")
        for name in ("stage2", "stage3", "nbv", "vpg"):
            _check(getattr(self, name).bootstrap == "target_network",
                   f"{name}.bootstrap = {getattr(self, name).bootstrap!r}: only stage 1 can bootstrap from the "
                   f"actor's values or actions; set {name}.bootstrap=target_network")
        if self.stage1.bootstrap == "actor":
            _check(not self.dqn.double_q,
                   "stage1.bootstrap = 'actor' stores the actor's max Q of the next state, so it cannot "
                   "take double Q's target-network value at the online argmax; set dqn.double_q=false or "
                   "stage1.bootstrap=target_network")
        if self.stage1.bootstrap == "actor_argmax":
            _check(not self.dqn.double_q,
                   "stage1.bootstrap = 'actor_argmax' already takes the target network's value at the "
                   "actor's argmax (a double-Q target); dqn.double_q would add the online network's full pass "
                   "over the next state: set dqn.double_q=false or stage1.bootstrap=target_network")
        d = self.parallel.devices
        for what, n in (("stage1.n_worlds", self.stage1.n_worlds), ("replay.capacity", self.replay.capacity),
                        ("dqn.batch_size", self.dqn.batch_size)):
            _check(n % d == 0, f"{what} = {n} is not divisible by the {d} devices asked for (--devices / "
                               f"parallel.devices): each device takes an equal share; make {what} a multiple "
                               f"of {d}, or use fewer devices")
        _within("seed", self.seed, 0, 2**32 - 1)
        _check(not self.benchmark.redrop_spilled or self.scene.placement == "pile",
               f"benchmark.redrop_spilled = {self.benchmark.redrop_spilled} drops spilled objects onto their pile "
               f"again, which needs scene.placement = 'pile' (got {self.scene.placement!r}): set "
               f"benchmark.redrop_spilled=0, or use benchmark.redraw_spilled instead")
        _check(self.scene.drop_margin < self.workspace.size / 2,
               f"scene.drop_margin ({self.scene.drop_margin} m) must be less than half of "
               f"workspace.size ({self.workspace.size} m): objects are dropped inside that margin")
        _check(self.camera.global_position[2] > self.workspace.table_z,
               f"camera.global_position {self.camera.global_position} must be above the table "
               f"(z > workspace.table_z = {self.workspace.table_z})")
        px = self.workspace.heightmap_px
        replay_bytes = self.replay.capacity * REPLAY_BYTES_PER_CELL * px * px
        _check(replay_bytes <= MAX_DEVICE_BYTES,
               f"replay.capacity = {self.replay.capacity:,} transitions of {px} x {px} heightmaps need "
               f"{replay_bytes / 2**30:,.0f} GiB ({REPLAY_BYTES_PER_CELL} bytes per cell), more than "
               f"{MAX_DEVICE_BYTES // 2**30} GiB; lower replay.capacity (at most "
               f"{MAX_DEVICE_BYTES // (REPLAY_BYTES_PER_CELL * px * px):,}) or workspace.heightmap_px")
        for name in ("stage1", "stage2", "stage3", "nbv", "vpg"):
            n = getattr(self, name).n_worlds
            maps = 2 if name == "vpg" else 1  # VPG: push and grasp maps
            q_bytes = 2 * n * maps * self.net.n_rotations * px * px
            _check(q_bytes <= MAX_DEVICE_BYTES,
                   f"{name}.n_worlds = {n:,} worlds need Q maps of "
                   f"{self.net.n_rotations} x {px} x {px} each, {q_bytes / 2**30:,.0f} GiB at 2 bytes per "
                   f"value, more than {MAX_DEVICE_BYTES // 2**30} GiB; lower {name}.n_worlds or "
                   f"workspace.heightmap_px")
        for name in ("stage1", "stage2", "stage3", "nbv"):  # (vpg's: check_vpg_fits)
            n = getattr(self, name).n_worlds
            _check(n <= self.replay.capacity,
                   f"{name}.n_worlds ({n:,}) exceeds replay.capacity ({self.replay.capacity:,}): one iteration "
                   f"adds up to one transition per world; raise replay.capacity or lower {name}.n_worlds")


def check_vpg_fits(cfg: Config) -> None:
    """VPG's stage against the scene and the replay (checked when it trains, so that configs
    with small scenes need not shrink a stage they do not run)."""
    v = cfg.vpg
    _check(v.max_objects <= cfg.scene.max_objects,
           f"vpg.max_objects ({v.max_objects}) exceeds scene.max_objects ({cfg.scene.max_objects}); lower it")
    _check(v.learning_starts <= cfg.replay.capacity,
           f"vpg.learning_starts ({v.learning_starts}) exceeds replay.capacity ({cfg.replay.capacity}): "
           f"learning would never start")
    _check(v.n_worlds <= cfg.replay.capacity,
           f"vpg.n_worlds ({v.n_worlds:,}) exceeds replay.capacity ({cfg.replay.capacity:,}): one iteration adds "
           f"up to one transition per world; raise replay.capacity or lower vpg.n_worlds")


def spilled_remedy(cfg: Config) -> tuple[int, int]:
    """(redraws, redrops) the benchmark gives a round whose pile spilled before its first
    attempt: ``benchmark.redraw_spilled`` and ``benchmark.redrop_spilled``, the latter's None
    read as ``DEFAULT_REDROPS`` on "pile" scenes without redraws, else 0."""
    b = cfg.benchmark
    redrop = b.redrop_spilled
    if redrop is None:
        redrop = DEFAULT_REDROPS if cfg.scene.placement == "pile" and not b.redraw_spilled else 0
    return b.redraw_spilled, redrop


def benchmark_groups(cfg: Config) -> tuple[int, ...]:
    """The benchmark's group sizes: ``benchmark.groups``, or 1..scene.max_objects when None."""
    g = cfg.benchmark.groups
    return tuple(range(1, cfg.scene.max_objects + 1)) if g is None else tuple(g)


def ggcnn_object_range(cfg: Config) -> tuple[int, int]:
    """(min, max) objects of GG-CNN's training scenes (max None: scene.max_objects)."""
    d = cfg.ggcnn_data
    return d.min_objects, (cfg.scene.max_objects if d.max_objects is None else d.max_objects)
