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


def save(run_dir: str, step: int, state: Any) -> None:
    """Writes ``state`` (a pytree of arrays) as checkpoint ``step`` and waits until it is on disk."""
    mngr = _manager(run_dir)
    mngr.save(int(step), args=ocp.args.StandardSave(_flatten(state)), force=True)
    mngr.wait_until_finished()
    mngr.close()


def latest_step(run_dir: str) -> Optional[int]:
    if not os.path.isdir(os.path.join(run_dir, CHECKPOINT_DIR)):
        return None
    mngr = _manager(run_dir)
    step = mngr.latest_step()
    mngr.close()
    return step


def restore(run_dir: str, target: Any, step: Optional[int] = None) -> tuple[Any, int]:
    """Restores into the structure of ``target``; returns ``(state, step)``.

    Raises CheckpointError with what to fix when there is no checkpoint or it does not fit.
    """
    if not os.path.isdir(run_dir):
        raise CheckpointError(f"run directory {run_dir!r} does not exist")
    mngr = _manager(run_dir, max_to_keep=None)
    step = mngr.latest_step() if step is None else int(step)
    if step is None or step not in mngr.all_steps():
        available = list(mngr.all_steps())
        mngr.close()
        raise CheckpointError(
            f"no checkpoint {'found' if step is None else step} in {run_dir}/{CHECKPOINT_DIR}"
            f" (available steps: {available or 'none'})"
        )
    abstract = jax.tree.map(ocp.utils.to_shape_dtype_struct, _flatten(target))
    try:
        flat = mngr.restore(step, args=ocp.args.StandardRestore(abstract))
    except (ValueError, KeyError, TypeError) as e:
        mngr.close()
        raise CheckpointError(
            f"checkpoint {step} in {run_dir} does not fit this run's state: it was written with a "
            f"different config (network, number of worlds, heightmap size or replay capacity). "
            f"Resume with the run's own config.json. Orbax said: {str(e)[:300]}"
        ) from e
    mngr.close()
    leaves, treedef = jax.tree.flatten(target)
    out = []
    for i, t in enumerate(leaves):
        r = flat.get(f"{i:05d}", t)
        if jax.dtypes.issubdtype(getattr(t, "dtype", None), jax.dtypes.prng_key):
            r = jax.random.wrap_key_data(r)
        out.append(r)
    return jax.tree.unflatten(treedef, out), step


def tree_equal(a: Any, b: Any) -> bool:
    """Exact equality of two pytrees of arrays (for resume tests)."""
    la = [_leaf_to_array(x) for x in jax.tree.leaves(a)]
    lb = [_leaf_to_array(x) for x in jax.tree.leaves(b)]
    return len(la) == len(lb) and all(np.array_equal(np.asarray(x), np.asarray(y)) for x, y in zip(la, lb))
