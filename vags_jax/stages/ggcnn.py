"""GG-CNN's training stage: Adam on the physics-labelled views, held-out accuracy in physics,
and its checkpoint inside a run directory (``train.py --stage ggcnn``).

* ``train_ggcnn``: ``ggcnn.train_steps`` Adam updates (``ggcnn_train.train_step``, rotation and
  zoom augmentation), ``ggcnn.batch_size`` views drawn uniformly (with replacement) from the
  training views per update; label maps and loss weights are drawn per batch from the stored
  candidates by ``ggcnn.labels`` (``ggcnn_labels.labels_and_weight``).  One jitted ``lax.scan`` runs a chunk of updates; after each
  chunk the (weighted) loss on the held-out views' labels (no augmentation) is computed.
* ``heldout_accuracy``: ``ggcnn_data.heldout_views`` fresh scenes from the held-out key stream
  (by default the scenes of the held-out views), rendered and given candidates exactly as for
  the data; then, in copies of each scene, GG-CNN's best grasp (``ggcnn_grasp.predict_grasp``)
  and the peak of the view's own label maps (the same post-processing, ``best_grasp``, on the
  maps drawn from the tried candidates) are executed.  Reported: ``ggcnn_success`` (share of
  views whose GG-CNN grasp succeeded), ``label_peak_success`` (the analytic labels' own success
  rate; a view with no successful candidate has empty maps, so its "peak" is a blind grasp),
  ``label_peak_success_labelled`` (the same over views with a success), ``candidate_success``
  (the random candidates' base rate) and ``views_with_success``.
* ``save_ggcnn`` / ``load_ggcnn``: orbax (``vags_jax.stages.checkpoint``) under ``RUN/ggcnn/``
  (``checkpoints/<step>/``, ``metrics.json``, ``config.json``), apart from stage 1's files.
"""
from __future__ import annotations

import functools
import json
import math
import os
import time
from typing import Callable, Optional

import jax
import jax.numpy as jnp
import numpy as np

from vags_jax.stages import checkpoint, progress
from vags_jax.config import Config
from vags_jax.ggcnn.data import (HELDOUT_STREAM, DataMaker, GGCNNDataset, ViewSet, Views, label_sizes,
                                 stream_keys)
from vags_jax.ggcnn.planner import image_to_world, predict_grasp
from vags_jax.ggcnn.labels import GraspCandidates, label_maps, labels_and_weight
from vags_jax.ggcnn.process import best_grasp
from vags_jax.ggcnn.train import GGCNNTrainState, init_train_state, make_optimizer, train_step
from vags_jax.nets.ggcnn import GGCNN

TRAIN_KEY_STREAM = 0x6767_0003  # folded into PRNGKey(cfg.seed): GG-CNN's init and batches
GGCNN_DIR = "ggcnn"
INFO_FILE = "metrics.json"
TERMS = ("quality", "cos", "sin", "width")


# ----------------------------------------------------------------------------- training


def train_key(cfg: Config) -> jax.Array:
    """The key ``train.py --stage ggcnn`` trains with (disjoint from the data's streams)."""
    return jax.random.fold_in(jax.random.PRNGKey(cfg.seed), TRAIN_KEY_STREAM)


def _device_candidates(vs: ViewSet) -> GraspCandidates:
    c = vs.candidates()
    return GraspCandidates(*(jnp.asarray(getattr(c, f)) for f in ("center", "angle", "length", "jaw", "success")))


def _take(c: GraspCandidates, idx) -> GraspCandidates:
    return jax.tree.map(lambda a: a[idx], c)


def _labels(cands: GraspCandidates, p: int, g):
    """Label maps and loss weight ``(B, p, p)`` of ``cands`` ``(B, K)`` by ``g.labels``."""
    return labels_and_weight(cands, p, p, g.width_scale, mode=g.labels, untried_weight=g.untried_weight)


def _chunk_impl(state: GGCNNTrainState, key, x_all, cands: GraspCandidates, first, *, cfg: Config, model,
                optimizer, n: int, total: int):
    """``n`` updates (those past update ``total`` leave the state unchanged) -> (state, key,
    mean metrics of the updates made)."""
    g = cfg.ggcnn
    p = x_all.shape[-1]

    def body(carry, i):
        state, key = carry
        key, k_idx, k_aug = jax.random.split(key, 3)
        idx = jax.random.randint(k_idx, (g.batch_size,), 0, x_all.shape[0])
        x = x_all[idx].astype(jnp.float32)
        labels, weight = _labels(_take(cands, idx), p, g)
        new, m = train_step(state, k_aug, x, labels, weight, model=model, optimizer=optimizer, cfg=g, augment=True)
        live = first + i < total
        state = jax.tree.map(lambda a, b: jnp.where(live, a, b), new, state)
        return (state, key), (m, live)

    (state, key), (m, live) = jax.lax.scan(body, (state, key), jnp.arange(n))
    w = live.astype(jnp.float32)
    means = {k: jnp.sum(v * w) / jnp.maximum(jnp.sum(w), 1.0) for k, v in m.items()}
    return state, key, means


def _heldout_impl(params, x_all, cands: GraspCandidates, *, cfg: Config, model, batch: int):
    """Loss terms on all held-out views (no augmentation), in batches of ``batch`` views."""
    n, p = x_all.shape[0], x_all.shape[-1]
    n_batches = -(-n // batch)
    idx = (jnp.arange(n_batches * batch) % n).reshape(n_batches, batch)
    weight = (jnp.arange(n_batches * batch) < n).reshape(n_batches, batch).astype(jnp.float32)

    def one(args):
        i, w = args
        pred = model.apply(params, x_all[i].astype(jnp.float32))
        lab, wmap = _labels(_take(cands, i), p, cfg.ggcnn)
        return {k: jnp.sum(jnp.mean(wmap * (getattr(pred, k) - getattr(lab, k)) ** 2, axis=(1, 2)) * w)
                for k in TERMS}

    sums = jax.lax.map(one, (idx, weight))
    out = {k: jnp.sum(v) / n for k, v in sums.items()}
    out["loss"] = sum(out[k] for k in TERMS)
    return out


def train_ggcnn(cfg: Config, dataset: GGCNNDataset, key, log: Optional[Callable[[str], None]] = None,
                chunk: Optional[int] = None, stop=None):
    """Trains GG-CNN on ``dataset`` -> ``(params, metrics)``.

    params: ``{"params": ...}`` of ``GGCNN()``.  metrics: ``{"history": [per chunk: step,
    loss and its four terms (mean over the chunk's updates), heldout_loss and its terms],
    "train_loss", "heldout_loss", "heldout_terms", "steps", "seconds"}``.  ``chunk``: updates
    per jitted scan (default: about a tenth of ``ggcnn.train_steps``).  ``stop``: an
    ``interrupts.StopRequests``; once it is requested training ends at the next chunk and
    ``metrics["steps"]`` says how far it got (below ``train_steps``; nothing is saved).
    """
    g = cfg.ggcnn
    total = g.train_steps
    chunk = max(1, min(total, chunk or -(-total // 10)))
    model = GGCNN()
    optimizer = make_optimizer(g)
    k_init, k_train = jax.random.split(jnp.asarray(key))
    state = init_train_state(k_init, g, model, optimizer)
    x_train = jnp.asarray(dataset.train.x)
    c_train = _device_candidates(dataset.train)
    x_held = jnp.asarray(dataset.heldout.x)
    c_held = _device_candidates(dataset.heldout)
    run = jax.jit(functools.partial(_chunk_impl, cfg=cfg, model=model, optimizer=optimizer, n=chunk, total=total))
    held = jax.jit(functools.partial(_heldout_impl, cfg=cfg, model=model,
                                     batch=min(dataset.heldout.n, max(g.batch_size, 32))))
    history = []
    t0 = time.time()
    done = 0
    run_s = 0.0  # seconds of the chunks, compiling excluded (the ETA)
    while done < total:
        tc = time.time()
        with progress.compile_step(f"GG-CNN's chunk of {chunk} updates", log if done == 0 else None) as clock:
            state, k_train, m = run(state, k_train, x_train, c_train, jnp.int32(done))
            h = jax.device_get(held(state.params, x_held, c_held))
        run_s += max(time.time() - tc - clock.seconds, 0.0)
        done = min(total, done + chunk)
        row = {"step": done, **{k: float(v) for k, v in jax.device_get(m).items()},
               "heldout_loss": float(h["loss"]), **{f"heldout_{k}": float(h[k]) for k in TERMS}}
        history.append(row)
        if not all(math.isfinite(row[k]) for k in ("loss", "heldout_loss")):
            raise FloatingPointError(f"GG-CNN's loss became non-finite by update {done} (train {row['loss']}, "
                                     f"held-out {row['heldout_loss']}); lower ggcnn.learning_rate")
        if log is not None:
            log(f"GG-CNN update {done}/{total} | loss {row['loss']:.4f} | held-out loss "
                f"{row['heldout_loss']:.4f} | {time.time() - t0:.0f} s | ETA "
                f"{progress.duration(progress.eta(total - done, run_s, done))}")
        if stop is not None and stop.requested:
            break
    last = history[-1]
    metrics = {"history": history, "steps": done, "train_loss": last["loss"], "heldout_loss": last["heldout_loss"],
               "heldout_terms": {k: last[f"heldout_{k}"] for k in TERMS}, "seconds": round(time.time() - t0, 2)}
    return state.params, metrics


# ----------------------------------------------------------------------------- held-out accuracy


def _policy_impl(params, v: Views, success, gap, *, cfg: Config, model, worlds: int):
    """GG-CNN's grasp and the label peak of each of S views, laid out for one grasp call of
    ``worlds`` scene copies: rows 0..S-1 GG-CNN, S..2S-1 the label peak, the rest repeats."""
    g, below = cfg.ggcnn, cfg.grasp.depth_below_surface
    s, p = v.x.shape[0], v.x.shape[-1]
    net, _ = predict_grasp(model, params, v.depth, v.pose, cfg.camera, g, below)
    length, jaw = label_sizes(cfg, v.filled, v.k_in, v.center, success, gap)
    maps = label_maps(GraspCandidates(v.center, v.angle, length, jaw, success), p, p, g.width_scale,
                      mode=g.labels)
    img = best_grasp(maps, g, v.valid)
    peak = image_to_world(img.pixel[:, None], img.angle[:, None], img.width_px[:, None], v.filled, v.k_in,
                          v.pose, below)
    position = jnp.concatenate([net.position, peak.position[:, 0]])
    yaw = jnp.concatenate([net.yaw, peak.yaw[:, 0]])
    rows = jnp.arange(worlds) % (2 * s)
    start = jnp.tile(v.pose[:, :3, 3], (2, 1))
    return rows % s, position[rows], yaw[rows], start[rows]


def heldout_accuracy(cfg: Config, env, params, key=None, maker: Optional[DataMaker] = None,
                     log: Optional[Callable[[str], None]] = None) -> dict:
    """Grasp success of GG-CNN (``params``) on ``ggcnn_data.heldout_views`` fresh scenes.

    key: root of the scenes' key stream (batch b uses ``fold_in(key, b)``); default the held-out
    stream of ``cfg.seed`` (the held-out views' own scenes; never the training stream).
    maker: a ``DataMaker`` of ``cfg`` to reuse its compiled programs (built on ``env`` when None).
    Returns a dict of shares (module docstring) and counts.
    """
    d = cfg.ggcnn_data
    maker = DataMaker(cfg, env) if maker is None else maker
    maker.check_fits(cfg)
    s = d.scenes_per_batch
    n_batches = -(-d.heldout_views // s)
    keys = stream_keys(cfg, HELDOUT_STREAM, n_batches, key)
    policy = jax.jit(functools.partial(_policy_impl, cfg=cfg, model=GGCNN(), worlds=maker.worlds))
    rows = {"ggcnn": [], "peak": [], "cand": [], "is_global": [], "error": []}
    t0 = time.time()
    for b in range(n_batches):
        v = maker.render(keys[b])
        success, gap, error = maker.candidate_trials(v)
        scene, position, yaw, start = policy(params, v, success, gap)
        ok, _, err = maker.execute(v.sim, scene, position, yaw, start)
        ok, err, success, error, is_global = jax.device_get((ok, err, success, error, v.is_global))
        rows["ggcnn"].append(ok[:s])
        rows["peak"].append(ok[s:2 * s])
        rows["cand"].append(success)
        rows["is_global"].append(is_global)
        rows["error"].append(error.any(axis=1) | err[:s] | err[s:2 * s])
    n = d.heldout_views
    r = {k: np.concatenate(v)[:n] for k, v in rows.items()}
    labelled = r["cand"].any(axis=1)
    close = ~r["is_global"]

    def share(x, where=None):
        x = x if where is None else x[where]
        return float(np.mean(x)) if x.size else None

    out = {
        "views": int(n), "ggcnn_success": share(r["ggcnn"]), "label_peak_success": share(r["peak"]),
        "label_peak_success_labelled": share(r["peak"], labelled), "candidate_success": share(r["cand"]),
        "views_with_success": share(labelled), "ggcnn_success_close": share(r["ggcnn"], close),
        "ggcnn_success_global": share(r["ggcnn"], ~close), "close_views": int(close.sum()),
        "physics_errors": int(r["error"].sum()), "seconds": round(time.time() - t0, 2),
    }
    if log is not None:
        pct = lambda x: "-" if x is None else f"{100 * x:.1f} %"
        log(f"GG-CNN held-out accuracy over {n} views: GG-CNN {pct(out['ggcnn_success'])}, label peak "
            f"{pct(out['label_peak_success'])}, random candidates {pct(out['candidate_success'])}, views with a "
            f"successful candidate {pct(out['views_with_success'])}")
    return out


# ----------------------------------------------------------------------------- checkpoint


def ggcnn_dir(run_dir: str) -> str:
    return os.path.join(run_dir, GGCNN_DIR)


def save_ggcnn(run_dir: str, params, info: dict, cfg: Optional[Config] = None, step: Optional[int] = None) -> str:
    """Writes GG-CNN's ``params`` as checkpoint ``step`` (default ``info["steps"]``, else 0)
    under ``RUN/ggcnn/``, with ``info`` as ``metrics.json`` and ``cfg`` as ``config.json``.
    Returns that directory."""
    out = ggcnn_dir(run_dir)
    os.makedirs(out, exist_ok=True)
    step = int(info.get("steps", 0) if step is None else step)
    checkpoint.save(out, step, {"params": params})
    if cfg is not None:
        checkpoint.save_config(out, cfg)
    tmp = os.path.join(out, INFO_FILE + ".tmp")
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump(info, f, indent=2, sort_keys=True)
    os.replace(tmp, os.path.join(out, INFO_FILE))
    return out


def abstract_params():
    """Shapes and dtypes (``jax.ShapeDtypeStruct``) of GG-CNN's parameters as a run saves them."""
    return jax.eval_shape(lambda k: GGCNN().init(k, jnp.zeros((1, 12, 12, 1), jnp.float32)), jax.random.PRNGKey(0))


def load_ggcnn(run_dir: str, step: Optional[int] = None):
    """GG-CNN's parameters saved in ``run_dir`` -> ``(params, step)`` (default: the latest).

    Raises ``checkpoint.CheckpointError`` (one line, saying what to do) when the run has no
    GG-CNN checkpoint, the checkpoint is damaged, or it holds other arrays than GG-CNN's.
    """
    out = ggcnn_dir(run_dir)
    retrain = f"python train.py --stage ggcnn --out {run_dir}"
    steps = checkpoint.checkpoint_steps(out) if os.path.isdir(out) else []
    if not steps:
        raise checkpoint.CheckpointError(
            f"run {run_dir} has no GG-CNN checkpoint ({out}): train one with {retrain}")
    if step is not None and int(step) not in steps:
        raise checkpoint.CheckpointError(
            f"run {run_dir} has no GG-CNN checkpoint {step} ({out} holds {steps}); pass one of those "
            f"or none for the latest")
    try:
        arrays, step = checkpoint.read(out, step)
    except checkpoint.CheckpointError as e:
        why = str(e).rsplit("; ", 1)[0] if "damaged" in str(e) else str(e)
        raise checkpoint.CheckpointError(
            f"the GG-CNN checkpoint of run {run_dir} cannot be used: {why}; delete {out} and train "
            f"it again with {retrain}") from None
    leaves = jax.tree.leaves(abstract_params())
    saved = arrays.get("params", {})
    problem = None if "params" in arrays else f"it has no part 'params' (parts: {sorted(arrays)})"
    for i, want in enumerate(leaves):
        if problem:
            break
        got = saved.get(f"{i:05d}")
        if got is None or got.shape != tuple(want.shape) or got.dtype != want.dtype:
            found = "nothing" if got is None else f"{got.shape} {got.dtype}"
            problem = f"leaf {i}: saved {found}, GG-CNN needs {tuple(want.shape)} {want.dtype}"
    if problem is None and len(saved) != len(leaves):
        problem = f"it holds {len(saved)} arrays, GG-CNN has {len(leaves)}"
    if problem:
        raise checkpoint.CheckpointError(
            f"checkpoint {step} in {out} does not hold GG-CNN's parameters ({problem}); delete {out} and "
            f"train it again with {retrain}")
    treedef = jax.tree.structure(abstract_params())
    params = jax.tree.unflatten(treedef, [jnp.asarray(saved[f"{i:05d}"]) for i in range(len(leaves))])
    return params, step
