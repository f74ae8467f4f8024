"""GG-CNN's training data, made and labelled in batched physics, and its on-disk cache.

One *batch* (``ggcnn_data.scenes_per_batch`` = S scenes, ``candidates`` = K grasps per view) is
two jitted programs chained on the device, with no Python loop over scenes or time inside them
and no host round trip between them (``DataMaker``): steps 1-4 (``render_views``), then steps
5-6 (``execute_grasps``; the held-out check reuses both, see ``DataMaker``):

1. S fresh random scenes of the config's own kind (piles, depth noise as configured), with
   object counts uniform in ``config.ggcnn_object_range(cfg)``, dropped and settled; the
   global heightmap of each is rendered (``VagsEnv.step_reset``).
2. A view per scene: with probability ``global_view_share`` the global camera pose, else a
   close view ``camera.viewpoint_height`` above a random object cell of the global heightmap
   (height above ``exploration.height_threshold``; any cell when none is), its xy shifted by
   a random offset of length up to ``view_jitter`` (uniform over that disc), looking straight
   down (``camera.viewpoint_pose``).
3. The raw camera image from there (``VagsEnv.camera_image``: the sensor model's noise and
   holes) -> GG-CNN's input ``x`` (S, P, P), its inpainted depth and intrinsics
   (``ggcnn_grasp.network_input``; P = ``ggcnn.input_size``).
4. K candidate grasps per view in the network image: centres drawn uniformly among the pixels
   that show an object (valid depth before inpainting, back-projected point higher than
   ``table_z + exploration.height_threshold``), falling back to any valid pixel, then to any
   pixel, when a view has none; angles uniform in [-pi/2, pi/2).  Each becomes a world grasp
   with ``ggcnn_grasp.image_to_world`` (``grasp.depth_below_surface`` under the surface seen
   at the pixel), the conversion GG-CNN's predictions go through, so a label and a prediction
   at one pixel mean the same grasp.
5. Every scene is copied K times (``Simulator.take_worlds``) and all S x K grasps run at once
   (``Simulator.grasp_batched``, starting from the view's camera position).  A candidate is a
   success when the simulator says so and neither its copy nor its scene had a physics error.
6. Label sizes in network pixels at the depth d seen at the centre, with the network
   intrinsics' fx: length = (measured pad gap after the lift + ``width_margin``) * fx / d
   (failures keep the full stroke: their centre third is where they count as tried),
   jaw = ``jaw`` * fx / d.

The dataset keeps only the network inputs (float16) and the candidates (``GraspCandidates``,
(N, K)); label maps are drawn per training batch (``ggcnn_labels.label_maps``, by ``ggcnn.labels``, a training setting: it does not
change the data).  Training
views and held-out views come from disjoint key streams (``TRAIN_STREAM``, ``HELDOUT_STREAM``
folded into ``PRNGKey(cfg.seed)``).

Cache: ``load_or_make`` keeps each dataset under ``DATA_DIR/<hash>/`` (``views.npz`` and
``meta.json``), the hash covering ``DATA_VERSION`` and every config field that can change the
data (``data_config``: everything but the sections and fields listed in ``NOT_DATA``).  A second
run with the same config reuses it; a damaged cache is reported and made again.
"""
from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import math
import os
import time
from typing import Callable, Optional

import flax.struct
import jax
import jax.numpy as jnp
import numpy as np

from vags_jax.perception import camera
from vags_jax import config as config_lib
from vags_jax.config import Config
from vags_jax.env import VagsEnv
from vags_jax.ggcnn.planner import image_to_world, network_input
from vags_jax.ggcnn.labels import GraspCandidates
from vags_jax.sim.simulator import SimState

# Bump when the way views or labels are made changes: every cached dataset is then remade.
DATA_VERSION = 1
# Key streams folded into PRNGKey(cfg.seed).
TRAIN_STREAM = 0x6767_0001
HELDOUT_STREAM = 0x6767_0002
# Config sections / fields that never change the data (training, post-processing, other stages).
NOT_DATA = {
    "net": None, "dqn": None, "replay": None, "stage1": None, "benchmark": None, "parallel": None,
    "exploration": ("daes", "eps_start", "eps_end", "eps_decay"),
    "ggcnn": ("quality_sigma", "angle_sigma", "width_sigma", "width_scale", "learning_rate",
              "batch_size", "zoom_range", "rotation", "train_steps", "labels", "untried_weight"),
}
VIEWS_FILE = "views.npz"
META_FILE = "meta.json"


def default_data_dir() -> str:
    """``$XDG_CACHE_HOME/vags_jax/ggcnn`` (``~/.cache/vags_jax/ggcnn``)."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "vags_jax", "ggcnn")


# ----------------------------------------------------------------------------- one batch


@dataclasses.dataclass(frozen=True)
class ViewSet:
    """N labelled views (host NumPy arrays).

    x: (N, P, P) float16 GG-CNN input; center: (N, K, 2) float32 [u, v]; angle, length, jaw:
    (N, K) float32 (radians, network pixels); success: (N, K) bool; gap: (N, K) float32
    measured pad gap (m, 0 on failure); is_global: (N,) bool global view; n_objects: (N,)
    int32 objects dropped; object_view: (N,) bool the view showed an object pixel (else its
    candidates fell back); physics_error: (N,) bool the scene or one of its copies failed.
    """

    x: np.ndarray
    center: np.ndarray
    angle: np.ndarray
    length: np.ndarray
    jaw: np.ndarray
    success: np.ndarray
    gap: np.ndarray
    is_global: np.ndarray
    n_objects: np.ndarray
    object_view: np.ndarray
    physics_error: np.ndarray

    @property
    def n(self) -> int:
        return int(self.x.shape[0])

    def candidates(self, idx=None) -> GraspCandidates:
        """The views' (or views ``idx``') candidates as ``GraspCandidates`` (..., K)."""
        pick = (lambda a: a) if idx is None else (lambda a: a[idx])
        return GraspCandidates(center=pick(self.center), angle=pick(self.angle), length=pick(self.length),
                               jaw=pick(self.jaw), success=pick(self.success))

    def arrays(self) -> dict:
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}


def _n_objects(cfg: Config, key, n: int) -> jax.Array:
    lo, hi = config_lib.ggcnn_object_range(cfg)
    return jax.random.randint(key, (n,), lo, hi + 1, jnp.int32)


def choose_views(cfg: Config, key, height: jax.Array, global_pose) -> tuple[jax.Array, jax.Array]:
    """Camera poses of S views from the scenes' global heightmaps ``height`` (S, H, W).

    Returns ``(pose (S, 4, 4), is_global (S,) bool)`` (module docstring, step 2).
    """
    d, ws = cfg.ggcnn_data, cfg.workspace
    s, h, w = height.shape
    k_cell, k_r, k_phi, k_global = jax.random.split(key, 4)
    obj = height > cfg.exploration.height_threshold
    logits = jnp.where(obj, 0.0, -1e9).reshape(s, h * w)  # no object cell: any cell
    cell = jax.random.categorical(k_cell, logits, axis=-1)
    pixel = jnp.stack([cell // w, cell % w], axis=-1).astype(jnp.int32)
    pose = camera.viewpoint_pose(pixel, height, ws, cfg.camera)
    r = d.view_jitter * jnp.sqrt(jax.random.uniform(k_r, (s,)))
    phi = jax.random.uniform(k_phi, (s,), minval=0.0, maxval=2 * math.pi)
    pose = pose.at[:, 0, 3].add(r * jnp.cos(phi)).at[:, 1, 3].add(r * jnp.sin(phi))
    is_global = jax.random.uniform(k_global, (s,)) < d.global_view_share
    pose = jnp.where(is_global[:, None, None], jnp.broadcast_to(global_pose, pose.shape), pose)
    return pose, is_global


def object_pixels(filled, valid, k_in, pose, table_z: float, threshold: float) -> jax.Array:
    """(S, P, P) bool: valid network pixels whose back-projected point (inpainted depth
    ``filled``, intrinsics ``k_in`` (S, 3, 3), pose (S, 4, 4)) lies more than ``threshold``
    above the table."""
    s, p, _ = filled.shape
    u = jnp.arange(p, dtype=jnp.float32)[None, None, :]
    v = jnp.arange(p, dtype=jnp.float32)[None, :, None]
    e = lambda a: a[:, None, None]
    fx, fy, cx, cy = e(k_in[:, 0, 0]), e(k_in[:, 1, 1]), e(k_in[:, 0, 2]), e(k_in[:, 1, 2])
    pc = jnp.stack(jnp.broadcast_arrays(filled * (u - cx) / fx, filled * (v - cy) / fy, filled), axis=-1)
    z = jnp.einsum("sj,shwj->shw", pose[:, 2, :3], pc) + e(pose[:, 2, 3])
    return valid & (z > table_z + threshold)


def sample_candidates(key, obj: jax.Array, valid: jax.Array, k: int):
    """K candidate centres and angles per view.

    obj, valid: (S, P, P) bool.  Centres are uniform over the object pixels; a view without
    one draws among its valid pixels, and one without those among all pixels.  Returns
    ``(center (S, K, 2) float32 [u, v], angle (S, K) in [-pi/2, pi/2), has_object (S,) bool)``.
    """
    s, p, _ = obj.shape
    k_px, k_ang = jax.random.split(key)
    # exp(-30) per valid pixel against 1 per object pixel: the fallbacks only matter when a
    # view has no object pixel (then valid pixels outweigh the others by exp(30)).
    logits = jnp.where(obj, 0.0, jnp.where(valid, -30.0, -60.0)).reshape(s, p * p)
    idx = jax.random.categorical(k_px, logits, axis=-1, shape=(k, s)).T  # (S, K)
    center = jnp.stack([idx % p, idx // p], axis=-1).astype(jnp.float32)
    angle = jax.random.uniform(k_ang, (s, k), minval=-math.pi / 2, maxval=math.pi / 2)
    return center, angle, obj.any(axis=(1, 2))


def _px_at(filled, center):
    """Inpainted depth (S, P, P) at integer centres (S, K, 2) [u, v] -> (S, K)."""
    s, p, _ = filled.shape
    c = jnp.clip(jnp.round(center).astype(jnp.int32), 0, p - 1)
    return jnp.take_along_axis(filled.reshape(s, -1), c[..., 1] * p + c[..., 0], axis=1)


@flax.struct.dataclass
class Views:
    """One batch of S rendered views and their K candidates (device arrays; ``render_views``).

    sim: SimState of the S scenes; depth: (S, h, w) raw camera depth (0 = missing); pose:
    (S, 4, 4); is_global, object_view: (S,) bool; n_objects: (S,) int32; x, filled: (S, P, P)
    network input and inpainted depth (m); valid: (S, P, P) bool network pixels with depth
    before inpainting; k_in: (S, 3, 3) network intrinsics; center: (S, K,
    2) [u, v]; angle: (S, K); position: (S, K, 3), yaw: (S, K) the candidates' world grasps.
    """

    sim: SimState
    depth: jax.Array
    pose: jax.Array
    is_global: jax.Array
    object_view: jax.Array
    n_objects: jax.Array
    x: jax.Array
    filled: jax.Array
    valid: jax.Array
    k_in: jax.Array
    center: jax.Array
    angle: jax.Array
    position: jax.Array
    yaw: jax.Array


def render_views(cfg: Config, env, key) -> Views:
    """Steps 1-4 of the module docstring for one batch of S scenes (pure; call
    ``env.prepare(S)`` before tracing it)."""
    d = cfg.ggcnn_data
    s, k = d.scenes_per_batch, d.candidates
    k_n, k_reset, k_view, k_cam, k_cand = jax.random.split(key, 5)
    n = _n_objects(cfg, k_n, s)
    state = env.step_reset(k_reset, n, observe=True)
    pose, is_global = choose_views(cfg, k_view, state.height, jnp.asarray(env.global_pose))
    img = env.camera_image(state.sim, pose, k_cam)
    x, filled, k_in, valid = network_input(img.depth, cfg.camera, cfg.ggcnn)
    obj = object_pixels(filled, valid, k_in, pose, cfg.workspace.table_z, cfg.exploration.height_threshold)
    center, angle, has_obj = sample_candidates(k_cand, obj, valid, k)
    g = image_to_world(center, angle, jnp.zeros_like(angle), filled, k_in, pose, cfg.grasp.depth_below_surface)
    return Views(sim=state.sim, depth=img.depth, pose=pose, is_global=is_global, object_view=has_obj,
                 n_objects=n, x=x, filled=filled, valid=valid, k_in=k_in, center=center, angle=angle,
                 position=g.position, yaw=g.yaw)


def grasp_worlds(cfg: Config) -> int:
    """W, the worlds of every grasp call: ``max(S * K, 2 * S)`` (the held-out check's second
    call grasps twice per scene and shares the compiled program)."""
    d = cfg.ggcnn_data
    return max(d.scenes_per_batch * d.candidates, 2 * d.scenes_per_batch)


def execute_grasps(env, sim_state: SimState, scene: jax.Array, position: jax.Array, yaw: jax.Array,
                   start: jax.Array):
    """Grasps in copies of scenes, all at once (pure).

    sim_state: the S scenes; scene: (W,) int32 which scene each world copies
    (``Simulator.take_worlds``); position (W, 3), yaw (W,), start (W, 3) (hand position before
    the approach).  Returns ``(success, gap, error)`` each (W,): gap = pad gap after the lift
    (m); error = a physics error or buffer overflow in the copy or its scene; success only
    where there is none.
    """
    rep = env.sim._take_worlds_impl(sim_state, scene)
    after, res = env.sim.grasp_batched(rep, position, yaw, start)
    error = after.error | after.overflow | sim_state.error[scene] | sim_state.overflow[scene]
    return res.success & ~error, res.gripper_gap, error


def _pad_rows(x: jax.Array, w: int) -> jax.Array:
    """(n, ...) -> (w, ...) by repeating rows cyclically (n <= w)."""
    return x[jnp.arange(w) % x.shape[0]]


def label_sizes(cfg: Config, filled, k_in, center, success, gap):
    """(length, jaw) (S, K) in network pixels (module docstring, step 6)."""
    d = cfg.ggcnn_data
    z = jnp.maximum(_px_at(filled, center), 1e-3)
    fx = k_in[:, 0, 0][:, None]
    opening = jnp.where(success, gap + d.width_margin, cfg.grasp.finger_stroke)
    return opening * fx / z, d.jaw * fx / z


class DataMaker:
    """The compiled pieces of the dataset and of the held-out check, for one config.

    ``render(key) -> Views`` (scenes, views, candidates) and ``execute(sim, scene, position,
    yaw, start)`` (W = ``grasp_worlds(cfg)`` grasps in scene copies) are the two jitted
    programs; a batch chains them on the device (no host round trip in between).  They are
    separate so that ``ggcnn_stage.heldout_accuracy`` runs the very same two programs (plus
    GG-CNN's small one) rather than compiling its own physics: on a CPU the physics compile
    takes minutes.
    """

    def __init__(self, cfg: Config, env=None):
        self.cfg = cfg
        self.key = program_key(cfg)
        self.env = VagsEnv(cfg) if env is None else env
        self.env.prepare(cfg.ggcnn_data.scenes_per_batch)
        self.worlds = grasp_worlds(cfg)
        self.render = jax.jit(functools.partial(render_views, cfg, self.env))
        self.execute = jax.jit(functools.partial(execute_grasps, self.env))
        self._finish = jax.jit(functools.partial(_finish_batch, cfg))

    def check_fits(self, cfg: Config) -> None:
        """ValueError unless this maker's programs make ``cfg``'s data (same ``program_key``)."""
        if program_key(cfg) != self.key:
            raise ValueError("this DataMaker was built for another config (scenes, camera, GG-CNN input or "
                             "grasp settings differ); build one with DataMaker(cfg)")

    def candidate_trials(self, v: Views):
        """Runs the K candidates of every view: ``(success, gap, error)`` each (S, K)."""
        s, k = v.yaw.shape
        w, n = self.worlds, s * k
        scene = _pad_rows(jnp.repeat(jnp.arange(s, dtype=jnp.int32), k), w)
        start = jnp.repeat(v.pose[:, :3, 3], k, axis=0)
        success, gap, error = self.execute(v.sim, scene, _pad_rows(v.position.reshape(n, 3), w),
                                           _pad_rows(v.yaw.reshape(n), w), _pad_rows(start, w))
        return success[:n].reshape(s, k), gap[:n].reshape(s, k), error[:n].reshape(s, k)

    def batch(self, key) -> dict:
        """One batch of labelled views: ``ViewSet``'s fields for S views (device arrays)."""
        v = self.render(key)
        return self._finish(v, *self.candidate_trials(v))



def program_key(cfg: Config) -> str:
    """What a ``DataMaker``'s programs depend on: ``data_config(cfg)`` without ``seed``,
    ``ggcnn_data.views`` and ``ggcnn_data.heldout_views`` (they only pick keys and batch counts)."""
    c = data_config(cfg)
    c.pop("seed", None)
    c["ggcnn_data"] = {k: v for k, v in c["ggcnn_data"].items() if k not in ("views", "heldout_views")}
    return json.dumps(c, sort_keys=True)


def _finish_batch(cfg: Config, v: Views, success, gap, error) -> dict:
    length, jaw = label_sizes(cfg, v.filled, v.k_in, v.center, success, gap)
    return dict(x=v.x.astype(jnp.float16), center=v.center, angle=v.angle, length=length, jaw=jaw,
                success=success, gap=jnp.where(success, gap, 0.0), is_global=v.is_global,
                n_objects=v.n_objects, object_view=v.object_view, physics_error=error.any(axis=1))


def stream_keys(cfg: Config, stream: int, n_batches: int, key=None) -> jax.Array:
    """(n_batches, 2) keys ``fold_in(root, b)``, root = ``key`` or
    ``fold_in(PRNGKey(cfg.seed), stream)``."""
    root = jax.random.fold_in(jax.random.PRNGKey(cfg.seed), stream) if key is None else jnp.asarray(key)
    return jax.vmap(lambda b: jax.random.fold_in(root, b))(jnp.arange(n_batches))


def make_views(cfg: Config, maker: DataMaker, n_views: int, stream: int,
               log: Optional[Callable[[str], None]] = None, label: str = "views") -> ViewSet:
    """``n_views`` labelled views of ``stream`` (batches of S scenes; the last batch's extra
    views are dropped).  A Python loop over batches."""
    maker.check_fits(cfg)
    s = cfg.ggcnn_data.scenes_per_batch
    n_batches = -(-n_views // s)
    keys = stream_keys(cfg, stream, n_batches)
    parts = []
    t0 = time.time()
    for b in range(n_batches):
        parts.append(jax.device_get(maker.batch(keys[b])))
        if log is not None and (b + 1 == n_batches or (b + 1) % max(1, n_batches // 10) == 0):
            done = min((b + 1) * s, n_views)
            rate = float(np.mean(np.concatenate([p["success"].ravel() for p in parts])))
            log(f"  {label}: {done}/{n_views} views, {done * cfg.ggcnn_data.candidates} grasps, "
                f"{100 * rate:.1f} % succeeded, {time.time() - t0:.0f} s")
    out = {k: np.concatenate([np.asarray(p[k]) for p in parts])[:n_views] for k in parts[0]}
    return ViewSet(**out)


# ----------------------------------------------------------------------------- dataset + cache


@dataclasses.dataclass(frozen=True)
class GGCNNDataset:
    """Training and held-out views, and ``info`` (the cache's meta: counts, timing, path)."""

    train: ViewSet
    heldout: ViewSet
    info: dict


def data_config(cfg: Config) -> dict:
    """The config fields that can change the data: ``to_dict(cfg)`` without ``NOT_DATA``."""
    out = config_lib.to_dict(cfg)
    for section, fields in NOT_DATA.items():
        if fields is None:
            out.pop(section, None)
        else:
            for f in fields:
                out[section].pop(f, None)
    return out


def data_hash(cfg: Config) -> str:
    """16 hex digits of sha256 over ``DATA_VERSION`` and ``data_config(cfg)``."""
    text = json.dumps({"version": DATA_VERSION, "config": data_config(cfg)}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def cache_path(cfg: Config, data_dir: Optional[str] = None) -> str:
    return os.path.join(data_dir or default_data_dir(), data_hash(cfg))


def summarize(train: ViewSet, heldout: ViewSet) -> dict:
    """Counts of a dataset: views, grasps tried, success shares."""
    def one(v: ViewSet) -> dict:
        return {"views": v.n, "grasps_tried": int(v.success.size),
                "success_share": float(v.success.mean()) if v.success.size else 0.0,
                "views_with_success": float(v.success.any(axis=1).mean()) if v.n else 0.0,
                "global_views": int(v.is_global.sum()), "views_without_object_pixels": int((~v.object_view).sum()),
                "physics_errors": int(v.physics_error.sum())}
    return {"train": one(train), "heldout": one(heldout)}


def _expected_shapes(cfg: Config, n: int) -> dict:
    p, k = cfg.ggcnn.input_size, cfg.ggcnn_data.candidates
    f32, b = np.dtype(np.float32), np.dtype(bool)
    return {"x": ((n, p, p), np.dtype(np.float16)), "center": ((n, k, 2), f32), "angle": ((n, k), f32),
            "length": ((n, k), f32), "jaw": ((n, k), f32), "success": ((n, k), b), "gap": ((n, k), f32),
            "is_global": ((n,), b), "n_objects": ((n,), np.dtype(np.int32)), "object_view": ((n,), b),
            "physics_error": ((n,), b)}


class DamagedCache(ValueError):
    """A cached dataset cannot be read or does not match its config."""


def read_cache(cfg: Config, path: str) -> GGCNNDataset:
    """The dataset cached at ``path`` for ``cfg``.  FileNotFoundError when there is none;
    DamagedCache (naming the file and what is wrong) when it cannot be used."""
    meta_path, views_path = os.path.join(path, META_FILE), os.path.join(path, VIEWS_FILE)
    if not os.path.exists(meta_path):
        raise FileNotFoundError(meta_path)
    try:
        with open(meta_path, encoding="utf-8") as f:
            meta = json.load(f)
        if not isinstance(meta, dict):
            raise ValueError("not a JSON object")
    except (OSError, UnicodeDecodeError, ValueError) as e:
        raise DamagedCache(f"{meta_path} is not valid JSON ({_first_line(e)})") from None
    if meta.get("version") != DATA_VERSION:
        raise DamagedCache(f"{meta_path} has data version {meta.get('version')!r}, not {DATA_VERSION}")
    if meta.get("config") != json.loads(json.dumps(data_config(cfg))):
        raise DamagedCache(f"{meta_path} was written for another config (its hash collides or it was edited)")
    d = cfg.ggcnn_data
    sets = {}
    try:
        with np.load(views_path, allow_pickle=False) as z:
            for name, n in (("train", d.views), ("heldout", d.heldout_views)):
                arrays = {}
                for field, (shape, dtype) in _expected_shapes(cfg, n).items():
                    key = f"{name}/{field}"
                    if key not in z.files:
                        raise DamagedCache(f"{views_path} has no array {key!r}")
                    a = z[key]
                    if a.shape != shape or a.dtype != dtype:
                        raise DamagedCache(f"{views_path}: {key} is {a.shape} {a.dtype}, expected {shape} {dtype}")
                    arrays[field] = a
                sets[name] = ViewSet(**arrays)
    except DamagedCache:
        raise
    except Exception as e:  # zipfile / numpy raise many types for truncated or garbled files
        raise DamagedCache(f"{views_path} cannot be read ({type(e).__name__}: {_first_line(e)})") from None
    info = dict(meta)
    info.pop("config", None)
    return GGCNNDataset(sets["train"], sets["heldout"], info)


def write_cache(cfg: Config, path: str, data: GGCNNDataset) -> None:
    """Writes ``views.npz`` then ``meta.json`` (each to a temporary name, then renamed; the
    meta file marks a complete cache)."""
    os.makedirs(path, exist_ok=True)
    arrays = {f"{name}/{k}": v for name, vs in (("train", data.train), ("heldout", data.heldout))
              for k, v in vs.arrays().items()}
    tmp = os.path.join(path, VIEWS_FILE + ".tmp")
    with open(tmp, "wb") as f:
        np.savez(f, **arrays)
    os.replace(tmp, os.path.join(path, VIEWS_FILE))
    meta = dict(data.info, config=data_config(cfg))
    tmp = os.path.join(path, META_FILE + ".tmp")
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump(meta, f, indent=2, sort_keys=True)
    os.replace(tmp, os.path.join(path, META_FILE))


def make_dataset(cfg: Config, maker: DataMaker, log: Optional[Callable[[str], None]] = None) -> GGCNNDataset:
    """Makes the training and held-out views (no cache)."""
    d = cfg.ggcnn_data
    t0 = time.time()
    train = make_views(cfg, maker, d.views, TRAIN_STREAM, log, "training")
    heldout = make_views(cfg, maker, d.heldout_views, HELDOUT_STREAM, log, "held-out")
    info = {"version": DATA_VERSION, "hash": data_hash(cfg), "seconds": round(time.time() - t0, 2),
            "platform": jax.default_backend(), "made_at": time.strftime("%Y-%m-%d %H:%M:%S"),
            "scenes_per_batch": d.scenes_per_batch, "candidates": d.candidates, **summarize(train, heldout)}
    return GGCNNDataset(train, heldout, info)


def load_or_make(cfg: Config, maker: Optional[DataMaker] = None, data_dir: Optional[str] = None,
                 log: Optional[Callable[[str], None]] = None) -> GGCNNDataset:
    """The cached dataset of ``cfg`` under ``data_dir`` (default ``default_data_dir()``), or a
    new one made (with ``maker``, built when None) and cached.  ``info["reused"]`` says which, ``info["path"]`` where.  A damaged
    cache is reported through ``log`` and made again."""
    say = log or (lambda _: None)
    path = cache_path(cfg, data_dir)
    try:
        data = read_cache(cfg, path)
        say(f"GG-CNN data: reusing the cache {path} ({data.train.n} training + {data.heldout.n} "
            f"held-out views, made in {data.info.get('seconds', '?')} s on {data.info.get('platform', '?')})")
        return dataclasses.replace(data, info=dict(data.info, reused=True, path=path))
    except FileNotFoundError:
        say(f"GG-CNN data: no cache for this config; making it in {path}")
    except DamagedCache as e:
        say(f"GG-CNN data: the cache is damaged: {e}; making it again")
    d = cfg.ggcnn_data
    say(f"GG-CNN data: {d.views} training + {d.heldout_views} held-out views, {d.candidates} grasps "
        f"each, {d.scenes_per_batch} scenes ({d.scenes_per_batch * d.candidates} worlds) per batch")
    data = make_dataset(cfg, DataMaker(cfg) if maker is None else maker, log)
    write_cache(cfg, path, data)
    t = data.info["train"]
    say(f"GG-CNN data: made in {data.info['seconds']:.1f} s: {t['grasps_tried']} training grasps, "
        f"{100 * t['success_share']:.1f} % succeeded, {100 * t['views_with_success']:.1f} % of views "
        f"with a success")
    return dataclasses.replace(data, info=dict(data.info, reused=False, path=path))


def _first_line(e, limit: int = 200) -> str:
    lines = str(e).strip().splitlines()
    text = lines[0] if lines else type(e).__name__
    return text if len(text) <= limit else text[:limit] + "..."
