"""Batched RGB-D rendering of MuJoCo scenes: a pure-JAX ray caster (default) or MJX's Warp renderer.

Usage::

    geometry = prepare_geometry(mj_model)                 # once, static (host numpy -> pytree)
    depth, rgb = render(geometry, d.geom_xpos, d.geom_xmat, geom_rgb, cam_pose, cam_cfg)

* ``depth`` (B, h, w) float32: z-distance along the optical axis (metres), 0 where nothing is
  hit or the hit is outside ``[cam_cfg.near, cam_cfg.far]``.
* ``rgb`` (B, h, w, 3) uint8: the hit geom's per-world colour ``geom_rgb[b, geom]`` with a
  little Lambert shading from a headlight at the camera; black where nothing is hit.

The "jax" backend intersects every pixel ray exactly with every rendered geom:
planes, boxes and convex meshes are convex polytopes (a list of half-spaces ``n . x <= c`` in
the geom frame) intersected with the Cyrus-Beck test; spheres, capsules (a cylinder plus two
spheres) and cylinders analytically.  The camera origin is shared by all rays of an image, so
per (geom, face) only one dot product with the ray direction is done per pixel.  Pixels are
processed in chunks (``chunk_pixels``) with ``lax.map`` to bound memory for large batches.
Ellipsoids, height fields and non-convex meshes are not supported (non-convex meshes are
rendered as their convex hull, with a warning).  Rays starting inside a geom do not hit it.

The "warp" backend (``prepare_geometry(..., backend="warp", cam_cfg=..., n_worlds=B)``) calls
``mujoco.mjx.render`` (needs warp-lang and an NVIDIA GPU); see `WarpGeometry`.
"""
from __future__ import annotations

import copy
import dataclasses
import importlib.util
import warnings
from typing import Any, NamedTuple, Optional

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from flax import struct
from mujoco import mjx
from scipy.spatial import ConvexHull

from vags_jax.perception import camera as cam_lib
from vags_jax.config import Camera, DepthNoise

_PLANE, _SPHERE, _CAPSULE, _CYLINDER, _BOX, _MESH = (
    int(mujoco.mjtGeom.mjGEOM_PLANE),
    int(mujoco.mjtGeom.mjGEOM_SPHERE),
    int(mujoco.mjtGeom.mjGEOM_CAPSULE),
    int(mujoco.mjtGeom.mjGEOM_CYLINDER),
    int(mujoco.mjtGeom.mjGEOM_BOX),
    int(mujoco.mjtGeom.mjGEOM_MESH),
)
AMBIENT = 0.4  # shade = AMBIENT + (1 - AMBIENT) * |cos(incidence)|
_INF = jnp.inf


# ----------------------------------------------------------------------------- geometry


@struct.dataclass
class Polytopes:
    """Convex polytopes with P half-spaces each, ``normals . x <= offsets`` in the geom frame."""

    geom_ids: jnp.ndarray  # (G,) int32 MuJoCo geom index
    normals: jnp.ndarray  # (G, P, 3) unit outward normals (zero rows = padding)
    offsets: jnp.ndarray  # (G, P); padding rows have offset 1
    is_box: jnp.ndarray  # (G,) bool: a box, whose offsets follow a per-world geom_size


@struct.dataclass
class Spheres:
    geom_ids: jnp.ndarray  # (S,) int32; a capsule contributes two spheres
    centers: jnp.ndarray  # (S, 3) centre in the geom frame
    radii: jnp.ndarray  # (S,)
    cap_end: jnp.ndarray  # (S,) 0 for a sphere, +1 / -1 for a capsule's end at z = +-size[1]


@struct.dataclass
class Cylinders:
    geom_ids: jnp.ndarray  # (C,) int32; a capsule contributes its cylinder part
    radii: jnp.ndarray  # (C,)
    half_heights: jnp.ndarray  # (C,) along the geom's local z


@struct.dataclass
class Geometry:
    """Static render geometry for the "jax" backend (a pytree; pass it to or close over in jit)."""

    polytopes: tuple  # of Polytopes, grouped by face count
    spheres: Optional[Spheres]
    cylinders: Optional[Cylinders]
    ngeom: int = struct.field(pytree_node=False)
    backend: str = struct.field(pytree_node=False, default="jax")


def default_render_mask(mj_model: mujoco.MjModel) -> np.ndarray:
    """(ngeom,) bool: every geom except those in geom group 3 (the gripper) is rendered."""
    return np.asarray(mj_model.geom_group) != 3


def _mesh_halfspaces(mj_model, mesh_id: int, name: str, tol: float = 1e-6):
    """Unique face planes (K, 3), (K,) of a convex mesh, in the geom frame."""
    va, vn = mj_model.mesh_vertadr[mesh_id], mj_model.mesh_vertnum[mesh_id]
    fa, fn = mj_model.mesh_faceadr[mesh_id], mj_model.mesh_facenum[mesh_id]
    verts = np.asarray(mj_model.mesh_vert[va : va + vn], np.float64)
    faces = np.asarray(mj_model.mesh_face[fa : fa + fn])
    tri = verts[faces]  # (F, 3, 3)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area = np.linalg.norm(n, axis=-1)
    keep = area > 1e-12
    n = n[keep] / area[keep, None]
    c = np.einsum("fc,fc->f", n, tri[keep, 0])
    centroid = verts.mean(0)
    flip = np.einsum("fc,c->f", n, centroid) > c  # make normals point away from the centroid
    n[flip], c[flip] = -n[flip], -c[flip]
    scale = np.abs(verts).max()
    convex = np.all(verts @ n.T <= c + 1e-5 * max(scale, 1e-3))
    if not convex:
        warnings.warn(f"render: mesh geom {name!r} is not convex; rendering its convex hull")
        hull = ConvexHull(verts)
        n, c = hull.equations[:, :3], -hull.equations[:, 3]
    # Merge coplanar triangles.
    key = np.round(np.concatenate([n, c[:, None] / max(scale, 1e-6)], axis=1) / 1e-5).astype(np.int64)
    _, first = np.unique(key, axis=0, return_index=True)
    first = np.sort(first)
    return n[first], c[first]


# Long (one reason): a single pass over the model's geoms fills every primitive table in step.
def prepare_geometry(
    mj_model: mujoco.MjModel,
    render_geom_mask=None,
    backend: str = "jax",
    *,
    cam_cfg: Optional[Camera] = None,
    n_worlds: Optional[int] = None,
    plane_extent: float = 100.0,
):
    """Static render geometry from a MuJoCo model.

    Args:
      mj_model: the model (geom types, sizes, mesh data).
      render_geom_mask: (ngeom,) bool, geoms to render; default `default_render_mask`.
      backend: "jax" (pure JAX ray caster, any device) or "warp" (MJX Warp renderer, GPU).
      cam_cfg, n_worlds: required for "warp" (its render context has a fixed camera and
        number of worlds).
      plane_extent: half-size used for infinite planes (size 0).
    Returns:
      `Geometry` ("jax") or `WarpGeometry` ("warp").
    """
    mask = default_render_mask(mj_model) if render_geom_mask is None else np.asarray(render_geom_mask, bool)
    if mask.shape != (mj_model.ngeom,):
        raise ValueError(f"render_geom_mask must have shape ({mj_model.ngeom},), got {mask.shape}")
    if backend == "warp":
        if cam_cfg is None or n_worlds is None:
            raise ValueError("prepare_geometry(backend='warp') needs cam_cfg and n_worlds")
        return WarpGeometry.create(mj_model, mask, cam_cfg, n_worlds)
    if backend != "jax":
        raise ValueError(f"render backend must be 'jax' or 'warp', got {backend!r}")

    polys: dict[int, list] = {}  # face count -> [(gid, normals, offsets)]
    sph, cyl = [], []
    for g in np.nonzero(mask)[0]:
        gtype, size = int(mj_model.geom_type[g]), np.asarray(mj_model.geom_size[g], np.float64)
        name = mujoco.mj_id2name(mj_model, mujoco.mjtObj.mjOBJ_GEOM, int(g)) or f"#{g}"
        if gtype == _BOX:
            eye = np.eye(3)
            polys.setdefault(6, []).append((g, np.concatenate([eye, -eye]), np.concatenate([size, size]), True))
        elif gtype == _PLANE:
            ex = size[0] if size[0] > 0 else plane_extent
            ey = size[1] if size[1] > 0 else plane_extent
            n = np.array([[0, 0, 1], [1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0]], np.float64)
            polys.setdefault(6, []).append((g, n, np.array([0.0, ex, ex, ey, ey]), False))
        elif gtype == _MESH:
            n, c = _mesh_halfspaces(mj_model, int(mj_model.geom_dataid[g]), name)
            polys.setdefault(len(n), []).append((g, n, c, False))
        elif gtype == _SPHERE:
            sph.append((g, (0.0, 0.0, 0.0), size[0], 0.0))
        elif gtype == _CYLINDER:
            cyl.append((g, size[0], size[1]))
        elif gtype == _CAPSULE:
            cyl.append((g, size[0], size[1]))
            sph += [(g, (0.0, 0.0, size[1]), size[0], 1.0), (g, (0.0, 0.0, -size[1]), size[0], -1.0)]
        else:
            raise ValueError(
                f"render: geom {name!r} has type {mujoco.mjtGeom(gtype).name}, which the jax "
                "renderer does not support (plane, box, convex mesh, sphere, capsule, cylinder); "
                "exclude it with render_geom_mask or model it as a convex mesh"
            )
    groups = []
    # Pad face counts up to a few buckets so that similar meshes share one group.
    buckets: dict[int, list] = {}
    for p, items in polys.items():
        pb = 6 if p <= 6 else int(8 * np.ceil(p / 8))
        buckets.setdefault(pb, []).extend(items)
    for pb, items in sorted(buckets.items()):
        nrm = np.zeros((len(items), pb, 3), np.float32)
        off = np.ones((len(items), pb), np.float32)
        for i, (_, n, c, _) in enumerate(items):
            nrm[i, : len(n)], off[i, : len(n)] = n, c
        groups.append(Polytopes(jax.device_put(np.asarray([it[0] for it in items], np.int32)), jax.device_put(nrm),
                                jax.device_put(off), jax.device_put(np.asarray([it[3] for it in items], bool))))
    spheres = (
        Spheres(
            jax.device_put(np.asarray([s[0] for s in sph], np.int32)),
            jax.device_put(np.asarray([s[1] for s in sph], np.float32)),
            jax.device_put(np.asarray([s[2] for s in sph], np.float32)),
            jax.device_put(np.asarray([s[3] for s in sph], np.float32)),
        )
        if sph
        else None
    )
    cylinders = (
        Cylinders(
            jax.device_put(np.asarray([c[0] for c in cyl], np.int32)),
            jax.device_put(np.asarray([c[1] for c in cyl], np.float32)),
            jax.device_put(np.asarray([c[2] for c in cyl], np.float32)),
        )
        if cyl
        else None
    )
    if not groups and spheres is None and cylinders is None:
        raise ValueError("render: no geom is rendered (render_geom_mask selects nothing supported)")
    return Geometry(tuple(groups), spheres, cylinders, int(mj_model.ngeom))


# ----------------------------------------------------------------------------- ray casting


class _Hit(NamedTuple):
    t: jnp.ndarray  # (n,) ray parameter = z-depth (rays have unit camera-z), inf = miss
    geom: jnp.ndarray  # (n,) int32 MuJoCo geom id, -1 = miss
    normal: jnp.ndarray  # (n, 3) world normal


def _closer(a: _Hit, b: _Hit) -> _Hit:
    take = b.t < a.t
    return _Hit(
        jnp.where(take, b.t, a.t),
        jnp.where(take, b.geom, a.geom),
        jnp.where(take[:, None], b.normal, a.normal),
    )


def _dot3(a, b):
    """Explicit 3-term dot over the last axis (fuses into the surrounding reductions)."""
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def _cast_polytopes(o, d, nw, num, ids) -> _Hit:
    """Rays o + t d, d (n, 3) vs polytopes with world planes nw (G, P, 3), num = c_w - nw.o (G, P)."""
    # Unrolled over the (static, small) face count: only (n, G) temporaries.
    n_rays, (g, p) = d.shape[0], num.shape
    t_in = jnp.full((n_rays, g), -_INF)
    t_out = jnp.full((n_rays, g), _INF)
    for k in range(p):
        denom = _dot3(d[:, None, :], nw[None, :, k, :])  # (n, G)
        ck = num[None, :, k]
        t = ck / denom
        t_in = jnp.maximum(t_in, jnp.where(denom < 0, t, jnp.where((denom == 0) & (ck < 0), _INF, -_INF)))
        t_out = jnp.minimum(t_out, jnp.where(denom > 0, t, _INF))
    hit = (t_in <= t_out) & (t_in > 0)
    t_hit = jnp.where(hit, t_in, _INF)
    best = jnp.argmin(t_hit, axis=-1)  # (n,)
    t_best = jnp.take_along_axis(t_hit, best[:, None], axis=-1)[:, 0]
    # Entering face of the winning polytope only: (n, P) work instead of (n, G, P).
    nb, cb = nw[best], num[best]  # (n, P, 3), (n, P)
    db = _dot3(d[:, None, :], nb)
    face = jnp.argmax(jnp.where(db < 0, cb / db, -_INF), axis=-1)
    normal = jnp.take_along_axis(nb, face[:, None, None], axis=1)[:, 0]
    return _Hit(t_best, jnp.where(jnp.isfinite(t_best), ids[best], -1), normal)


def _cast_spheres(o, d, centers_w, radii, ids) -> _Hit:
    """Rays vs spheres with world centres (S, 3)."""
    oc = o[None] - centers_w  # (S, 3)
    a = _dot3(d, d)[:, None]  # (n, 1)
    b = _dot3(d[:, None, :], oc[None])  # (n, S)
    c = _dot3(oc, oc) - radii**2  # (S,)
    disc = b * b - a * c[None]
    t = (-b - jnp.sqrt(jnp.maximum(disc, 0.0))) / a
    t = jnp.where((disc >= 0) & (t > 0) & (c[None] > 0), t, _INF)
    best = jnp.argmin(t, axis=-1)
    t_best = jnp.take_along_axis(t, best[:, None], axis=-1)[:, 0]
    p = o[None] + jnp.where(jnp.isfinite(t_best), t_best, 0.0)[:, None] * d
    normal = (p - centers_w[best]) / radii[best][:, None]
    return _Hit(t_best, jnp.where(jnp.isfinite(t_best), ids[best], -1), normal)


def _cast_cylinders(o, d, rot, pos, radii, half_h, ids) -> _Hit:
    """Rays vs finite cylinders along their local z; rot (C, 3, 3) geom-to-world, pos (C, 3)."""
    ol = jnp.einsum("cji,cj->ci", rot, o[None] - pos)  # (C, 3) origin in geom frames
    dl = jnp.einsum("cji,nj->nci", rot, d)  # (n, C, 3)
    a = dl[..., 0] ** 2 + dl[..., 1] ** 2
    b = dl[..., 0] * ol[None, :, 0] + dl[..., 1] * ol[None, :, 1]
    c = (ol[:, 0] ** 2 + ol[:, 1] ** 2 - radii**2)[None]
    disc = b * b - a * c
    sq = jnp.sqrt(jnp.maximum(disc, 0.0))
    axial = a < 1e-12
    t1 = jnp.where(axial, jnp.where(c < 0, -_INF, _INF), (-b - sq) / jnp.where(axial, 1.0, a))
    t2 = jnp.where(axial, jnp.where(c < 0, _INF, -_INF), (-b + sq) / jnp.where(axial, 1.0, a))
    radial_miss = ~axial & (disc < 0)
    tz1 = (-half_h[None] - ol[None, :, 2]) / dl[..., 2]
    tz2 = (half_h[None] - ol[None, :, 2]) / dl[..., 2]
    inside_z = jnp.abs(ol[None, :, 2]) <= half_h[None]
    flat = dl[..., 2] == 0
    tz_in = jnp.where(flat, jnp.where(inside_z, -_INF, _INF), jnp.minimum(tz1, tz2))
    tz_out = jnp.where(flat, jnp.where(inside_z, _INF, -_INF), jnp.maximum(tz1, tz2))
    t_in = jnp.maximum(t1, tz_in)
    t_out = jnp.minimum(t2, tz_out)
    hit = ~radial_miss & (t_in <= t_out) & (t_in > 0)
    t_hit = jnp.where(hit, t_in, _INF)
    best = jnp.argmin(t_hit, axis=-1)
    t_best = jnp.take_along_axis(t_hit, best[:, None], axis=-1)[:, 0]
    cap = jnp.take_along_axis(tz_in >= t1, best[:, None], axis=-1)[:, 0]
    olb, dlb = ol[best], jnp.take_along_axis(dl, best[:, None, None], axis=1)[:, 0]
    pl = olb + jnp.where(jnp.isfinite(t_best), t_best, 0.0)[:, None] * dlb
    n_side = jnp.concatenate([pl[:, :2], jnp.zeros_like(pl[:, :1])], axis=-1) / radii[best][:, None]
    n_cap = jnp.concatenate([jnp.zeros_like(pl[:, :2]), jnp.sign(pl[:, 2:])], axis=-1)
    normal = jnp.einsum("nij,nj->ni", rot[best], jnp.where(cap[:, None], n_cap, n_side))
    return _Hit(t_best, jnp.where(jnp.isfinite(t_best), ids[best], -1), normal)


def _world_frame(geometry: Geometry, geom_xpos, geom_xmat, origin, geom_size=None):
    """Per-world, per-pixel-independent quantities: world planes, sphere centres, cylinders.

    geom_size: optional (ngeom, 3) MuJoCo geom sizes of this world (objects of drawn sizes);
    boxes, spheres, capsules and cylinders then take their sizes from it instead of the
    compiled model's (planes and meshes never change size).
    """
    polys = []
    for g in geometry.polytopes:
        rot, pos = geom_xmat[g.geom_ids], geom_xpos[g.geom_ids]  # (G, 3, 3), (G, 3)
        offsets = g.offsets
        if geom_size is not None:  # box faces: n = +-e_i, offset = half side i
            box_off = _dot3(jnp.abs(g.normals), geom_size[g.geom_ids][:, None, :])
            offsets = jnp.where(g.is_box[:, None], box_off, offsets)
        nw = jnp.einsum("gij,gpj->gpi", rot, g.normals)
        cw = offsets + _dot3(nw, pos[:, None, :])
        polys.append((nw, cw - _dot3(nw, origin[None, None, :]), g.geom_ids))
    sph = None
    if geometry.spheres is not None:
        s = geometry.spheres
        centers_l, radii = s.centers, s.radii
        if geom_size is not None:
            size = geom_size[s.geom_ids]
            radii = size[:, 0]
            centers_l = jnp.zeros_like(centers_l).at[:, 2].set(s.cap_end * size[:, 1])
        centers = geom_xpos[s.geom_ids] + jnp.einsum("sij,sj->si", geom_xmat[s.geom_ids], centers_l)
        sph = (centers, radii, s.geom_ids)
    cyl = None
    if geometry.cylinders is not None:
        c = geometry.cylinders
        radii, half_h = c.radii, c.half_heights
        if geom_size is not None:
            radii, half_h = geom_size[c.geom_ids, 0], geom_size[c.geom_ids, 1]
        cyl = (geom_xmat[c.geom_ids], geom_xpos[c.geom_ids], radii, half_h, c.geom_ids)
    return polys, sph, cyl


def _cast(o, d, polys, sph, cyl) -> _Hit:
    """Nearest hit of rays o + t d, d (n, 3), against all rendered geoms."""
    n = d.shape[0]
    hit = _Hit(jnp.full((n,), _INF), jnp.full((n,), -1, jnp.int32), jnp.zeros((n, 3)))
    for nw, num, ids in polys:
        hit = _closer(hit, _cast_polytopes(o, d, nw, num, ids))
    if sph is not None:
        hit = _closer(hit, _cast_spheres(o, d, *sph))
    if cyl is not None:
        hit = _closer(hit, _cast_cylinders(o, d, *cyl))
    return hit


class RenderOutput(NamedTuple):
    depth: jnp.ndarray  # (B, h, w) float32 z-depth, 0 = missing
    rgb: jnp.ndarray  # (B, h, w, 3) uint8
    geom_id: jnp.ndarray  # (B, h, w) int32 MuJoCo geom id, -1 = nothing (segmentation)
    cos_incidence: jnp.ndarray  # (B, h, w) float32 |cos| of the angle between ray and normal


def _cast_one(geometry, geom_xpos, geom_xmat, cam_pose, cam_cfg, chunk_pixels, geom_size=None):
    """One world, "jax" backend: (ngeom, 3), (ngeom, 3, 3), (4, 4) -> (depth (h, w) float32, 0 =
    nothing hit in [near, far]; geom id (h, w) int32, -1 = nothing hit; |cos incidence| (h, w))."""
    h, w = cam_cfg.height, cam_cfg.width
    rays = cam_lib.pixel_rays(cam_cfg).reshape(-1, 3)
    origin = cam_pose[:3, 3]
    dirs = rays @ cam_pose[:3, :3].T  # (N, 3) world directions, unit camera-z
    n = h * w
    chunk = min(chunk_pixels, n)
    n_chunks = -(-n // chunk)
    dirs = jnp.pad(dirs, ((0, n_chunks * chunk - n), (0, 0)), constant_values=1.0)
    polys, sph, cyl = _world_frame(geometry, geom_xpos, geom_xmat, origin, geom_size)

    def chunk_fn(d):
        hit = _cast(origin, d, polys, sph, cyl)
        cos = jnp.abs(_dot3(hit.normal, d)) / jnp.sqrt(_dot3(d, d))
        return hit.t, hit.geom, cos

    if n_chunks == 1:
        t, gid, cos = chunk_fn(dirs)
    else:
        t, gid, cos = jax.lax.map(chunk_fn, dirs.reshape(n_chunks, chunk, 3))
    t, gid, cos = t.reshape(-1)[:n], gid.reshape(-1)[:n], cos.reshape(-1)[:n]
    valid = (t >= cam_cfg.near) & (t <= cam_cfg.far)
    depth = jnp.where(valid, t, 0.0).astype(jnp.float32)
    cos = jnp.where(gid >= 0, cos, 0.0)
    return depth.reshape(h, w), gid.reshape(h, w), cos.reshape(h, w)


def depth_and_segmentation(geometry, geom_xpos, geom_xmat, cam_pose, cam_cfg: Camera, chunk_pixels: int = 32768,
                           geom_size=None):
    """Render B worlds without colour: what the heightmaps need.

    Args: as `render_full`, without the colours.
    Returns:
      depth (B, h, w) float32 z-depth, 0 = missing; geom_id (B, h, w) int32 MuJoCo geom id,
      -1 = nothing; cos_incidence (B, h, w) float32 from the exact hit normals ("jax"
      backend), or None ("warp" backend: the renderer gives no normals; estimate them from
      the depth image and ``geom_id`` with `normals_from_depth` or `cos_incidence_at`).
    """
    if getattr(geometry, "backend", "jax") == "warp":
        depth, seg = geometry.depth_and_segmentation(geom_xpos, geom_xmat, cam_pose, cam_cfg, geom_size)
        return depth, jnp.where(seg >= 0, seg, -1).astype(jnp.int32), None
    geom_xpos = jnp.asarray(geom_xpos, jnp.float32)
    geom_xmat = jnp.asarray(geom_xmat, jnp.float32).reshape(geom_xpos.shape[:-1] + (3, 3))
    pose = jnp.asarray(cam_pose, jnp.float32)
    if geom_size is None:
        fn = lambda p, m, c: _cast_one(geometry, p, m, c, cam_cfg, chunk_pixels)  # noqa: E731
        return jax.vmap(fn)(geom_xpos, geom_xmat, pose)
    fn = lambda p, m, c, sz: _cast_one(geometry, p, m, c, cam_cfg, chunk_pixels, sz)  # noqa: E731
    return jax.vmap(fn)(geom_xpos, geom_xmat, pose, jnp.asarray(geom_size, jnp.float32))


def shade(geom_id, cos_incidence, geom_rgb):
    """Pixel colours from what was hit: the geom's colour with a headlight's Lambert shading.

    Args:
      geom_id: (B, N) int32 geom hit per pixel, -1 = nothing (black).
      cos_incidence: (B, N) |cos| of the angle between ray and surface normal.
      geom_rgb: (B, ngeom, 3) uint8 per-world geom colours.
    Returns:
      (B, N, 3) uint8.
    """
    base = jnp.take_along_axis(jnp.asarray(geom_rgb, jnp.uint8).astype(jnp.float32),
                               jnp.maximum(geom_id, 0)[..., None], axis=1)
    color = base * (AMBIENT + (1.0 - AMBIENT) * cos_incidence)[..., None]
    return jnp.where((geom_id >= 0)[..., None], jnp.clip(jnp.round(color), 0, 255), 0).astype(jnp.uint8)


def render_full(geometry, geom_xpos, geom_xmat, geom_rgb, cam_pose, cam_cfg: Camera, chunk_pixels: int = 32768,
                geom_size=None):
    """Render B worlds, returning depth, colour, segmentation and incidence (`RenderOutput`).

    Args:
      geometry: from `prepare_geometry` (backend "jax" or "warp").
      geom_xpos: (B, ngeom, 3) geom positions (mjx Data.geom_xpos).
      geom_xmat: (B, ngeom, 3, 3) geom rotations (mjx Data.geom_xmat).
      geom_rgb: (B, ngeom, 3) uint8 per-world geom colours.
      cam_pose: (B, 4, 4) camera-to-world poses (OpenCV camera frame).
      cam_cfg: image size and intrinsics (static).
      chunk_pixels: rays traced together per world ("jax" backend); lower it to save memory.
      geom_size: optional (B, ngeom, 3) per-world MuJoCo geom sizes (objects whose size is drawn
        per reset, ``SimState.geom_size``); None: the compiled model's sizes.
    """
    depth, gid, cos = depth_and_segmentation(geometry, geom_xpos, geom_xmat, cam_pose, cam_cfg, chunk_pixels,
                                             geom_size)
    if cos is None:
        cos = normals_from_depth(depth, cam_cfg, gid)
    b, h, w = depth.shape
    rgb = shade(gid.reshape(b, -1), cos.reshape(b, -1), geom_rgb).reshape(b, h, w, 3)
    return RenderOutput(depth.astype(jnp.float32), rgb, gid, cos)


def render(geometry, geom_xpos, geom_xmat, geom_rgb, cam_pose, cam_cfg: Camera, chunk_pixels: int = 32768,
           geom_size=None):
    """Render B worlds -> (depth (B, h, w) float32, rgb (B, h, w, 3) uint8).  See `render_full`."""
    out = render_full(geometry, geom_xpos, geom_xmat, geom_rgb, cam_pose, cam_cfg, chunk_pixels, geom_size)
    return out.depth, out.rgb


def model_colors(mj_model: mujoco.MjModel, n_worlds: int = 1) -> np.ndarray:
    """(n_worlds, ngeom, 3) uint8 geom colours from the model's geom_rgba (a default geom_rgb)."""
    rgb = np.clip(np.round(np.asarray(mj_model.geom_rgba)[:, :3] * 255), 0, 255).astype(np.uint8)
    return np.broadcast_to(rgb, (n_worlds,) + rgb.shape).copy()


# ----------------------------------------------------------------------------- sensor noise


def depth_edges(depth, jump: float, width: int):
    """(..., h, w) bool: pixels within ``width`` pixels of a depth discontinuity > ``jump`` m.

    A discontinuity is a pair of 4-neighbours whose depths differ by more than ``jump`` (a
    missing pixel, depth 0, next to a valid one counts too); both sides are marked, then the
    mask is dilated by ``width - 1`` pixels (``width = 0``: no edges).
    """
    if width <= 0:
        return jnp.zeros(depth.shape, bool)
    dx = jnp.abs(jnp.diff(depth, axis=-1)) > jump  # (..., h, w - 1)
    dy = jnp.abs(jnp.diff(depth, axis=-2)) > jump  # (..., h - 1, w)
    pad_x = [(0, 0)] * (depth.ndim - 1)
    pad_y = [(0, 0)] * (depth.ndim - 2)
    edge = (jnp.pad(dx, pad_x + [(1, 0)]) | jnp.pad(dx, pad_x + [(0, 1)])
            | jnp.pad(dy, pad_y + [(1, 0), (0, 0)]) | jnp.pad(dy, pad_y + [(0, 1), (0, 0)]))
    if width > 1:
        k = 2 * (width - 1) + 1
        lead = depth.ndim - 2
        edge = jax.lax.reduce_window(edge, False, jax.lax.bitwise_or, (1,) * lead + (k, k),
                                     (1,) * depth.ndim, "SAME")
    return edge


def add_depth_noise(key, depth, cos_incidence, noise_cfg: DepthNoise, fx: float = 618.62):
    """A structured-light / active-stereo sensor's depth from exact depth (pure; identity
    when ``noise_cfg.enabled`` is False).  The model and its parameters: `config.DepthNoise`.

    Args:
      key: PRNG key.
      depth: (..., h, w) exact z-depth, 0 = nothing hit (stays missing).
      cos_incidence: (..., h, w) |cos| of the angle between pixel ray and surface normal
        (`RenderOutput.cos_incidence`); pass ones to skip the steep-face dropout.
      noise_cfg: the sensor model.
      fx: focal length in pixels (disparity quantisation).
    Returns:
      (..., h, w) float32 sensor depth, 0 where the sensor returns nothing.
    """
    if not noise_cfg.enabled:
        return depth
    k_noise, k_edge, k_drop = jax.random.split(key, 3)
    depth = jnp.asarray(depth, jnp.float32)
    steep = cos_incidence < np.cos(np.deg2rad(noise_cfg.grazing_dropout_deg))
    edge = depth_edges(depth, noise_cfg.edge_jump, noise_cfg.edge_width)
    edge_lost = edge & (jax.random.uniform(k_edge, depth.shape) < noise_cfg.edge_dropout)
    dropped = jax.random.uniform(k_drop, depth.shape) < noise_cfg.dropout_prob
    sigma = noise_cfg.sigma_base + noise_cfg.sigma_quadratic * (depth - 0.4) ** 2
    noisy = depth + sigma * jax.random.normal(k_noise, depth.shape, jnp.float32)
    if noise_cfg.disparity_step > 0:
        fb = fx * noise_cfg.baseline  # disparity (px) = fb / z
        disparity = fb / jnp.maximum(noisy, 1e-6)
        q = jnp.round(disparity / noise_cfg.disparity_step) * noise_cfg.disparity_step
        noisy = fb / jnp.maximum(q, 1e-6)
    keep = (depth > 0) & ~steep & ~edge_lost & ~dropped & (noisy > 0)
    return jnp.where(keep, noisy, 0.0).astype(jnp.float32)


# ----------------------------------------------------------------------------- warp backend


def _incidence_from_neighbours(p, right, left, down, up, ray):
    """|cos incidence| from a surface point and its four neighbours' points.

    Args:
      p: (..., 3) the pixel's camera-frame point; right / left / down / up: ``(point (..., 3),
        usable (...) bool)`` of the neighbour one column / row away.
      ray: (..., 3) the pixel's ray direction.
    Returns:
      (...) float32: a central difference where both neighbours on an axis are usable, a
      one-sided one where one is, and 1 (not steep) where an axis has none.
    """
    def tangent(a, b):
        (pa, oka), (pb, okb) = a, b
        d = jnp.where((oka & okb)[..., None], pa - pb,
                      jnp.where(oka[..., None], pa - p, jnp.where(okb[..., None], p - pb, 0.0)))
        return d, oka | okb

    dx, okx = tangent(right, left)
    dy, oky = tangent(down, up)
    n = jnp.cross(dx, dy)
    n = n / jnp.maximum(jnp.linalg.norm(n, axis=-1, keepdims=True), 1e-12)
    cos = jnp.abs(_dot3(n, ray)) / jnp.linalg.norm(ray, axis=-1)
    return jnp.where(okx & oky, cos, 1.0)


def normals_from_depth(depth, cam_cfg: Camera, geom_id=None):
    """|cos incidence| (..., h, w) estimated from a depth image by finite differences (0 at holes).

    Args:
      depth: (..., h, w) z-depth, 0 = missing.
      geom_id: optional (..., h, w) int geom hit per pixel (-1 = nothing), the renderer's
        segmentation.  Given, each difference uses only neighbours on the same geom inside the
        image (one-sided at a geom's silhouette; 1 where an axis has no such neighbour), so
        pixels along an object's edge keep their own face's incidence.  Without it, central
        differences over all four neighbours, wrapping around at the image borders: across a
        depth jump they give a grazing incidence, which the sensor model then drops as a
        steep face (2.2x the steep pixels of the exact normals on the ``gpu`` scenes,
        ``bench/incidence_estimate.py``).
    """
    depth = jnp.asarray(depth, jnp.float32)
    pts = cam_lib.backproject(depth, cam_cfg)  # (..., h, w, 3) camera frame
    ray = cam_lib.pixel_rays(cam_cfg)
    h, w = depth.shape[-2:]
    if geom_id is None:
        ones = jnp.ones(depth.shape, bool)
        nb = lambda shift, axis: (jnp.roll(pts, shift, axis=axis - 1), ones)  # noqa: E731
    else:
        gid = jnp.asarray(geom_id)
        row = jnp.arange(h)[:, None]
        col = jnp.arange(w)[None, :]
        inside = {(-1, -1): col < w - 1, (1, -1): col > 0, (-1, -2): row < h - 1, (1, -2): row > 0}

        def nb(shift, axis):
            same = (jnp.roll(gid, shift, axis=axis) == gid) & (gid >= 0) & (jnp.roll(depth, shift, axis=axis) > 0)
            return jnp.roll(pts, shift, axis=axis - 1), same & inside[shift, axis]

    cos = _incidence_from_neighbours(pts, nb(-1, -1), nb(1, -1), nb(-1, -2), nb(1, -2), ray)
    return jnp.where(depth > 0, cos, 0.0)


def cos_incidence_at(depth, pixel, cam_cfg: Camera, geom_id=None):
    """`normals_from_depth` evaluated at chosen pixels only (the same finite differences).

    Args:
      depth: (B, h, w) z-depth images, 0 = missing.
      pixel: (B, M) int32 pixel index ``row * w + col`` into each image.
      geom_id: optional (B, h, w) int segmentation, as in `normals_from_depth`.
    Returns:
      (B, M) float32 |cos incidence| at those pixels (0 where their depth is 0).
    """
    b, h, w = depth.shape
    flat = depth.reshape(b, -1)
    row, col = pixel // w, pixel % w
    cx, cy = cam_cfg.principal_point
    gflat = None if geom_id is None else jnp.asarray(geom_id).reshape(b, -1)
    own = None if gflat is None else jnp.take_along_axis(gflat, pixel, axis=1)

    def ray(r, c):  # as `camera.pixel_rays`
        u = (c.astype(jnp.float32) - cx) / cam_cfg.fx
        v = (r.astype(jnp.float32) - cy) / cam_cfg.fy
        return jnp.stack([u, v, jnp.ones_like(u)], axis=-1)

    def neighbour(r, c):  # as `camera.backproject`; indices wrap like `jnp.roll` (unusable with geom_id)
        idx = (r % h) * w + c % w
        z = jnp.take_along_axis(flat, idx, axis=1)
        if gflat is None:
            usable = jnp.ones(z.shape, bool)
        else:
            inside = (r >= 0) & (r < h) & (c >= 0) & (c < w)
            usable = inside & (jnp.take_along_axis(gflat, idx, axis=1) == own) & (own >= 0) & (z > 0)
        return z[..., None] * ray(r % h, c % w), usable

    p = jnp.take_along_axis(flat, pixel, axis=1)[..., None] * ray(row, col)
    cos = _incidence_from_neighbours(p, neighbour(row, col + 1), neighbour(row, col - 1),
                                     neighbour(row + 1, col), neighbour(row - 1, col), ray(row, col))
    return jnp.where(jnp.take_along_axis(flat, pixel, axis=1) > 0, cos, 0.0)


def check_renderer(cam_cfg: Camera) -> None:
    """ValueError when ``cam_cfg.renderer`` cannot run on this machine (the Warp renderer needs
    warp-lang and JAX on an NVIDIA GPU); checked before anything compiles."""
    if cam_cfg.renderer != "warp":
        return
    if importlib.util.find_spec("warp") is None:
        raise ValueError("camera.renderer=warp needs warp-lang, which is not installed: pip install "
                         "'vags_jax[warp]' on an NVIDIA GPU machine, or use --set camera.renderer=jax (the gpu presets "
                         "choose warp)")
    if jax.default_backend() != "gpu":
        raise ValueError(f"camera.renderer=warp needs an NVIDIA GPU, but JAX runs on {jax.default_backend()} here: "
                         f"run it on a GPU machine, or use --set camera.renderer=jax (the ray caster, any device; the gpu "
                         f"presets choose warp)")


@dataclasses.dataclass(eq=False)
class WarpGeometry:
    """MJX Warp renderer behind `depth_and_segmentation` / `render_full` (needs warp-lang and
    an NVIDIA GPU; its tests skip elsewhere).

    Built by ``prepare_geometry(mj_model, mask, backend="warp", cam_cfg=cam, n_worlds=B)``.
    A camera named ``vags_cam`` (or else camera 0) of `mj_model` is given our intrinsics
    (on a copy of the model); at render time its pose is overwritten per world.  Geoms are
    selected by geom group: `render_geom_mask` must be expressible as "all geoms in these
    groups".  Colours (`render_full`) come from the segmentation output mapped through our
    per-world `geom_rgb`, shaded with normals estimated from the depth image.  Warp samples pixel
    centres at (px + 0.5); the principal point is shifted by half a pixel to match our
    convention (pixel u samples (u - cx) / fx).  Warp's depth is already planar z-depth.
    """

    mjx_model: Any
    context: Any
    template: Any  # batched mjx.Data (B worlds) used for fields we do not set
    cam_id: int
    n_worlds: int
    ngeom: int
    backend: str = "warp"

    @staticmethod
    def create(mj_model, mask, cam_cfg: Camera, n_worlds: int) -> "WarpGeometry":
        import mujoco.mjx.warp as mjxw  # optional extra: warp-lang

        if not mjxw.WARP_INSTALLED:
            raise RuntimeError(
                "render backend 'warp' needs warp-lang and an NVIDIA GPU: pip install "
                "'vags_jax[warp]' (mujoco-mjx[warp]), or use backend='jax'"
            )
        import warp

        if jax.default_backend() != "gpu" or not warp.is_cuda_available():
            raise RuntimeError(
                "render backend 'warp' needs an NVIDIA GPU (JAX on CUDA and warp with CUDA); "
                "use backend='jax' on this machine"
            )
        groups = np.asarray(mj_model.geom_group)
        enabled = sorted(int(g) for g in np.unique(groups[mask]))
        if not np.array_equal(mask, np.isin(groups, enabled)):
            raise ValueError(
                "render backend 'warp' selects geoms by group only; render_geom_mask must be "
                f"'all geoms in groups {enabled}'"
            )
        if mj_model.ncam == 0:
            raise ValueError(
                "render backend 'warp' needs a camera in the model: add "
                "<camera name=\"vags_cam\"/> to the worldbody (its pose is set per world)"
            )
        m = copy.copy(mj_model)  # we edit its camera
        cid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, "vags_cam")
        cid = 0 if cid < 0 else cid
        w, h = cam_cfg.width, cam_cfg.height
        cx, cy = cam_cfg.principal_point
        s = 1e-5  # sensor "metres" per pixel; only ratios matter
        m.cam_resolution[cid] = (w, h)
        m.cam_sensorsize[cid] = (w * s, h * s)
        # From mujoco_warp compute_ray: x/z = ((px + .5) - w/2 + cx_m / s) / (fx_m / s) and
        # y_cv/z = ((py + .5) - h/2 + cy_m / s) / (fy_m / s)  (y flipped: MuJoCo cameras are y-up).
        m.cam_intrinsic[cid] = (
            cam_cfg.fx * s,
            cam_cfg.fy * s,
            (w / 2 - 0.5 - cx) * s,
            (h / 2 - 0.5 - cy) * s,
        )
        m.cam_projection[cid] = mujoco.mjtProjection.mjPROJ_PERSPECTIVE
        mx = mjx.put_model(m, impl="warp")
        ctx = mjx.create_render_context(
            m,
            nworld=n_worlds,
            cam_res=(w, h),
            render_rgb=False,
            render_depth=True,
            render_seg=True,
            enabled_geom_groups=enabled,
            cam_active=[cid],
            use_textures=False,
            use_shadows=False,
            enable_backface_culling=cam_cfg.warp_backface_culling,
            # Vertex normals only shade RGB, which we do not ask Warp for; off, mesh hits skip
            # the interpolation (our colours come from segmentation + depth, see render_full).
            enable_vertex_normals=False,
        )
        # Batched warp Data must come from a vmapped make_data: MJX's warp FFI knows which
        # fields are per world, and a plain broadcast of every leaf is rejected.
        d = jax.jit(jax.vmap(lambda _: mjx.make_data(m, impl="warp")))(jnp.arange(n_worlds))
        return WarpGeometry(mx, ctx, d, cid, n_worlds, int(m.ngeom))

    def depth_and_segmentation(self, geom_xpos, geom_xmat, cam_pose, cam_cfg: Camera, geom_size=None):
        """The Warp renderer's own part of `render`: (depth (B, h, w) float32 m, 0 = nothing
        hit, seg (B, h, w) geom id or -1).  geom_size: optional (B, ngeom, 3) per-world sizes,
        passed to MuJoCo Warp as a batched model field (its BVH and ray tests read it)."""
        b = geom_xpos.shape[0]
        if b != self.n_worlds:
            raise ValueError(f"warp render context was made for {self.n_worlds} worlds, got {b}")
        # Inside a loop over render groups (VagsEnv.observe's lax.map), the inputs are slices
        # of the whole batch.  XLA on the GPU then fuses those slices into a copy of the
        # render's FFI call and keeps the original too, because the call has side effects:
        # every group was rendered twice (an H100 trace showed two 57 ms render kernels per
        # group).  Materialising the inputs behind a barrier leaves nothing to fuse.
        if geom_size is None:
            geom_xpos, geom_xmat, cam_pose = jax.lax.optimization_barrier((geom_xpos, geom_xmat, cam_pose))
        else:
            geom_xpos, geom_xmat, cam_pose, geom_size = jax.lax.optimization_barrier(
                (geom_xpos, geom_xmat, cam_pose, jnp.asarray(geom_size, jnp.float32)))
        # MuJoCo cameras look along -z with y up: R_mj = R_cv @ diag(1, -1, -1).
        rot_mj = cam_pose[:, :3, :3] * jnp.array([1.0, -1.0, -1.0])
        d = self.template.replace(
            geom_xpos=jnp.asarray(geom_xpos, jnp.float32),
            geom_xmat=jnp.asarray(geom_xmat, jnp.float32).reshape(b, -1, 3, 3),
            cam_xpos=self.template.cam_xpos.at[:, self.cam_id].set(cam_pose[:, :3, 3]),
            cam_xmat=self.template.cam_xmat.at[:, self.cam_id].set(rot_mj),
        )
        ctx = self.context.pytree()

        def one(m, dd):
            dd = mjx.refit_bvh(m, dd, ctx)
            _, depth, seg, dd = mjx.render_with_segmentation(m, dd, ctx)
            return depth, seg

        if geom_size is None:
            depth_raw, seg_raw = jax.vmap(one, in_axes=(None, 0))(self.mjx_model, d)
        else:
            m = self.mjx_model.replace(geom_size=geom_size)
            axes = jax.tree.map(lambda _: None, self.mjx_model).replace(geom_size=0)
            depth_raw, seg_raw = jax.vmap(one, in_axes=(axes, 0))(m, d)
        # Camera slot 0 of the context is our only active camera.
        # get_depth returns clip(raw / scale, 0, 1): scale by `far` and undo it.
        depth = mjx.get_depth(ctx, 0, depth_raw, cam_cfg.far)[..., 0] * cam_cfg.far
        seg = mjx.get_segmentation(ctx, 0, seg_raw)
        depth = jnp.where((depth >= cam_cfg.near) & (depth <= cam_cfg.far) & (seg >= 0), depth, 0.0)
        return depth, seg
