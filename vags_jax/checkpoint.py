"""Orbax save / restore of a training run's full state, with its config beside it.

A run directory looks like::

    runs/NAME/
      config.json          the Config the run was started with (vags_jax.config.to_dict)
      checkpoints/<step>/  orbax checkpoints of the whole training carry (any pytree of arrays)
      metrics.jsonl        one JSON object per logged chunk (written by train.py)

Restoring needs a *target* pytree of the same structure (built from the same config), so a
checkpoint from a different config fails with a message that says which config differs,
rather than an orbax shape error from deep inside.
"""
from __future__ import annotations

import dataclasses
import json
import os
from typing import Any, Optional

import jax
import numpy as np
import orbax.checkpoint as ocp

from vags_jax import config as config_lib

CONFIG_FILE = "config.json"
CHECKPOINT_DIR = "checkpoints"


class CheckpointError(ValueError):
    """A checkpoint is missing, or does not fit the run that tries to load it."""


def save_config(run_dir: str, cfg: config_lib.Config) -> None:
    os.makedirs(run_dir, exist_ok=True)
    with open(os.path.join(run_dir, CONFIG_FILE), "w") as f:
        json.dump(config_lib.to_dict(cfg), f, indent=2, sort_keys=True)


def load_config(run_dir: str) -> config_lib.Config:
    path = os.path.join(run_dir, CONFIG_FILE)
    if not os.path.isfile(path):
        raise CheckpointError(
            f"no {CONFIG_FILE} in {run_dir!r}: is this a run directory written by train.py?"
        )
    with open(path) as f:
        return config_lib.from_dict(config_lib.Config, json.load(f))


def _manager(run_dir: str, max_to_keep: Optional[int] = 3) -> ocp.CheckpointManager:
    path = os.path.abspath(os.path.join(run_dir, CHECKPOINT_DIR))
    return ocp.CheckpointManager(path, options=ocp.CheckpointManagerOptions(max_to_keep=max_to_keep))


def _leaf_to_array(x):
    """Typed PRNG keys are stored as their raw uint32 data."""
    if jax.dtypes.issubdtype(getattr(x, "dtype", None), jax.dtypes.prng_key):
        return jax.random.key_data(x)
    return x


def _flatten(tree: Any) -> dict[str, Any]:
    """{index: leaf} of the non-empty leaves (orbax refuses zero-size arrays, which mjx.Data has)."""
    leaves = [_leaf_to_array(x) for x in jax.tree.leaves(tree)]
    return {f"{i:05d}": x for i, x in enumerate(leaves) if np.size(x) > 0}


def _unflatten(target: Any, flat: dict[str, Any]) -> Any:
    leaves, treedef = jax.tree.flatten(target)
    out = []
    for i, t in enumerate(leaves):
        r = flat.get(f"{i:05d}", t)  # empty leaves were not saved: keep the target's
        if jax.dtypes.issubdtype(getattr(t, "dtype", None), jax.dtypes.prng_key):
            r = jax.random.wrap_key_data(r)
        out.append(r)
    return jax.tree.unflatten(treedef, out)


def _parts(state: Any) -> dict[str, Any]:
    """Top-level named parts of a state dataclass (or dict): saved, and restorable, separately."""
    if dataclasses.is_dataclass(state):
        return {f.name: getattr(state, f.name) for f in dataclasses.fields(state)}
    if isinstance(state, dict):
        return dict(state)
    return {"state": state}


def save(run_dir: str, step: int, state: Any) -> None:
    """Writes ``state`` (a dataclass / dict of pytrees of arrays) as checkpoint ``step``.

    Each top-level field is stored under its name, so one part (e.g. ``learner``) can be
    restored without building or reading the others (``restore_part``).
    """
    tree = {name: _flatten(part) for name, part in _parts(state).items()}
    mngr = _manager(run_dir)
    mngr.save(int(step), args=ocp.args.StandardSave(tree), force=True)
    mngr.wait_until_finished()
    mngr.close()


def _open_step(run_dir: str, step: Optional[int]):
    if not os.path.isdir(run_dir):
        raise CheckpointError(f"run directory {run_dir!r} does not exist")
    if not os.path.isdir(os.path.join(run_dir, CHECKPOINT_DIR)):
        raise CheckpointError(f"no checkpoints in {run_dir!r}: train it first (python train.py --out {run_dir})")
    mngr = _manager(run_dir, max_to_keep=None)
    step = mngr.latest_step() if step is None else int(step)
    if step is None or step not in mngr.all_steps():
        available = list(mngr.all_steps())
        mngr.close()
        raise CheckpointError(
            f"no checkpoint {'found' if step is None else step} in {run_dir}/{CHECKPOINT_DIR}"
            f" (available steps: {available or 'none'})"
        )
    return mngr, step


def _check_fits(run_dir: str, step: int, want: dict) -> None:
    """Compares the wanted {part: {leaf: ShapeDtypeStruct}} with the checkpoint's metadata, so a
    checkpoint of another config is refused before orbax starts reading (a failed orbax read
    leaves coroutines behind that spam the interpreter's exit)."""
    path = os.path.abspath(os.path.join(run_dir, CHECKPOINT_DIR))
    mngr = ocp.CheckpointManager(path, item_handlers=ocp.StandardCheckpointHandler())
    try:
        saved = getattr(mngr.item_metadata(step), "tree", None)
    finally:
        mngr.close()
    if not isinstance(saved, dict):
        return  # no metadata to compare with: orbax will check
    for name, leaves in want.items():
        if name not in saved:
            raise _mismatch(run_dir, step, f"it has no part {name!r} (parts: {sorted(saved)})")
        got = saved[name]
        for k, v in leaves.items():
            g = got.get(k)
            if g is None or tuple(g.shape) != tuple(v.shape) or np.dtype(g.dtype) != np.dtype(v.dtype):
                found = "nothing" if g is None else f"{tuple(g.shape)} {g.dtype}"
                raise _mismatch(run_dir, step, f"{name} leaf {k}: saved {found}, this run needs "
                                               f"{tuple(v.shape)} {np.dtype(v.dtype)}")
        extra = sorted(set(got) - set(leaves))
        if extra:
            raise _mismatch(run_dir, step, f"{name} has {len(extra)} more leaves than this run's state")


def _mismatch(run_dir, step, e) -> CheckpointError:
    return CheckpointError(
        f"checkpoint {step} in {run_dir} does not fit this run's state: it was written with a "
        f"different config (network, number of worlds, heightmap size or replay capacity). "
        f"Use the run's own config.json. Orbax said: {str(e)[:300]}"
    )


def restore(run_dir: str, target: Any, step: Optional[int] = None) -> tuple[Any, int]:
    """Restores into the structure of ``target``; returns ``(state, step)``.

    Raises CheckpointError with what to fix when there is no checkpoint or it does not fit.
    """
    mngr, step = _open_step(run_dir, step)
    parts = _parts(target)
    abstract = {name: jax.tree.map(ocp.utils.to_shape_dtype_struct, _flatten(p)) for name, p in parts.items()}
    try:
        _check_fits(run_dir, step, abstract)
    except CheckpointError:
        mngr.close()
        raise
    try:
        flat = mngr.restore(step, args=ocp.args.StandardRestore(abstract))
    except (ValueError, KeyError, TypeError) as e:
        raise _mismatch(run_dir, step, e) from e
    finally:
        mngr.close()
    restored = {name: _unflatten(p, flat[name]) for name, p in parts.items()}
    if dataclasses.is_dataclass(target):
        return dataclasses.replace(target, **restored), step
    return (restored if isinstance(target, dict) else restored["state"]), step


def restore_part(run_dir: str, name: str, target: Any, step: Optional[int] = None) -> tuple[Any, int]:
    """Restores only the top-level part ``name`` (e.g. "learner") into ``target``'s structure."""
    mngr, step = _open_step(run_dir, step)
    want = {name: jax.tree.map(ocp.utils.to_shape_dtype_struct, _flatten(target))}
    try:
        _check_fits(run_dir, step, want)
    except CheckpointError:
        mngr.close()
        raise
    try:
        flat = mngr.restore(step, args=ocp.args.PyTreeRestore(
            item=want, restore_args=jax.tree.map(lambda _: ocp.RestoreArgs(restore_type=np.ndarray), want),
            partial_restore=True))
    except (ValueError, KeyError, TypeError, FileNotFoundError) as e:
        raise _mismatch(run_dir, step, e) from e
    finally:
        mngr.close()
    got = flat.get(name, {}) if isinstance(flat, dict) else {}
    for k, v in want[name].items():
        if k not in got or tuple(np.shape(got[k])) != tuple(v.shape) or np.dtype(got[k].dtype) != v.dtype:
            found = "missing" if k not in got else f"{np.shape(got[k])} {got[k].dtype}"
            raise _mismatch(run_dir, step, f"part {name!r} leaf {k}: saved {found}, wanted {v.shape} {v.dtype}")
    flat = {name: got}
    return _unflatten(target, {k: jax.numpy.asarray(v) for k, v in flat[name].items()}), step


def tree_equal(a: Any, b: Any) -> bool:
    """Exact equality of two pytrees of arrays (for resume tests)."""
    la = [_leaf_to_array(x) for x in jax.tree.leaves(a)]
    lb = [_leaf_to_array(x) for x in jax.tree.leaves(b)]
    return len(la) == len(lb) and all(np.array_equal(np.asarray(x), np.asarray(y)) for x, y in zip(la, lb))
