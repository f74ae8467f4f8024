"""Orbax save / restore of a training run's full state, with its config beside it.

A run directory looks like::

    runs/NAME/
      config.json          the Config the run was started with (vags_jax.config.to_dict)
      checkpoints/<step>/  orbax checkpoints of the whole training carry (any pytree of arrays)
      metrics.jsonl        one JSON object per logged chunk (written by train.py)

Restoring needs a *target* pytree of the same structure (built from the same config), so a
checkpoint from a different config fails with a message that says which config differs,
rather than an orbax shape error from deep inside.  A damaged run directory (config.json
missing, not JSON or not a valid config; a checkpoint whose files are truncated or garbled) is
named in a one-line ``CheckpointError`` saying which file and what to do.  ``read`` loads a
checkpoint's arrays as saved, needing no target, so a caller can check a checkpoint before
building (and compiling) the state it fits into; ``fit`` then checks and places them.
"""
from __future__ import annotations

import contextlib
import dataclasses
import json
import logging
import math
import os
import re
import sys
import time
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
    """The run's config.json as a Config; CheckpointError naming the file when it is missing,
    not JSON, or not a valid config."""
    if not os.path.isdir(run_dir):
        raise CheckpointError(f"run directory {run_dir!r} does not exist")
    path = os.path.join(run_dir, CONFIG_FILE)
    if not os.path.isfile(path):
        raise CheckpointError(
            f"no {CONFIG_FILE} in {run_dir!r}: is this a run directory written by train.py?"
        )
    try:
        with open(path, encoding="utf-8") as f:
            data = json.load(f)
    except (OSError, UnicodeDecodeError, ValueError) as e:
        raise CheckpointError(
            f"{path} is damaged ({_first_line(e)}): it is not the JSON train.py writes; restore it "
            f"from a copy, or start a new run in another directory"
        ) from None
    try:
        return config_lib.from_saved(config_lib.Config, data)
    except (ValueError, TypeError) as e:
        raise CheckpointError(
            f"{path} is not a valid config ({_first_line(e)}); was it edited, or written by another "
            f"version? Fix that entry, or start a new run in another directory"
        ) from None


def _first_line(e, limit: int = 300) -> str:
    text = str(e).strip().splitlines()
    text = text[0] if text else type(e).__name__
    text = text.split(" [tensorstore_spec=")[0]
    return text if len(text) <= limit else text[:limit] + "..."


def _short_reason(e: BaseException) -> str:
    """Orbax / tensorstore messages nest "context: context: reason" around quoted paths: keep
    the reason and the last file named."""
    text = _first_line(e, limit=2000)
    found = list(re.finditer(r'local file "([^"]+)"', text))
    if not found:
        return _first_line(e)
    reason = text[found[-1].end():].lstrip(": ") or text
    return f"{found[-1].group(1)}: {reason[:200]}"


@contextlib.contextmanager
def _quiet():
    """Orbax logs (through absl) what it could not parse before raising or carrying on; every
    such problem ends in a CheckpointError here, so its log lines would only be noise."""
    log = logging.getLogger("absl")
    level = log.level
    log.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        log.setLevel(level)


def _closed_loop_filter(hook):
    def unraisable(u):
        # A failed orbax read leaves tensorstore callbacks that find their asyncio loop closed.
        if isinstance(u.exc_value, RuntimeError) and "Event loop is closed" in str(u.exc_value):
            return
        hook(u)

    unraisable.vags_jax_filter = True
    return unraisable


class _LeftoverReadTasks(logging.Filter):
    """The other reads of a failed orbax restore end as asyncio tasks / futures whose exceptions
    nobody retrieves; asyncio logs each (a traceback) when it is collected, often at exit."""

    def filter(self, record):
        msg = record.getMessage()
        return not ("exception was never retrieved" in msg and "OCDBT" in msg)  # Task or Future


def _mute_closed_loop_callbacks() -> None:
    """Installed before any read (the leftovers of a failed read show up while it is still
    failing, and later).  Both filters drop only those leftovers."""
    if not getattr(sys.unraisablehook, "vags_jax_filter", False):
        sys.unraisablehook = _closed_loop_filter(sys.unraisablehook)
    log = logging.getLogger("asyncio")
    if not any(isinstance(f, _LeftoverReadTasks) for f in log.filters):
        log.addFilter(_LeftoverReadTasks())


def _root_cause(e: BaseException) -> BaseException:
    seen = set()
    while id(e) not in seen:
        seen.add(id(e))
        nxt = e.__cause__ or e.__context__
        if nxt is None:
            break
        e = nxt
    return e


def checkpoint_steps(run_dir: str) -> list[int]:
    """Steps of the complete checkpoints in ``run_dir`` (sorted; [] when there are none).
    Reads the directory listing only."""
    path = os.path.join(run_dir, CHECKPOINT_DIR)
    if not os.path.isdir(path):
        return []
    with _quiet():
        mngr = _manager(run_dir, max_to_keep=None)
        try:
            return sorted(int(s) for s in mngr.all_steps())
        finally:
            mngr.close()


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


class PendingSave:
    """A checkpoint that Orbax is still copying off the device and writing in the background
    (``save(..., wait=False)``).  ``finish()`` waits for the files (once; later
    calls return at once) -> the seconds it waited.  Until then the step is not on disk
    (``checkpoint_steps`` does not list it)."""

    def __init__(self, mngr: ocp.CheckpointManager, step: int):
        self._mngr, self.step = mngr, step

    def finish(self) -> float:
        if self._mngr is None:
            return 0.0
        t0 = time.time()
        self._mngr.wait_until_finished()
        self._mngr.close()
        self._mngr = None
        return time.time() - t0


def save(run_dir: str, step: int, state: Any, wait: bool = True) -> Optional[PendingSave]:
    """Writes ``state`` (a dataclass / dict of pytrees of arrays) as checkpoint ``step``.

    Each top-level field is stored under its name, so one part (e.g. ``learner``) can be
    restored without building or reading the others (``restore_part``).  ``wait=False``
    returns while Orbax still copies the arrays to host and writes the files: a ``PendingSave``
    to ``finish()`` before the process ends or the step is read.  Until then the arrays must
    not be donated (the caller hands copies on; ``driver``).
    """
    tree = {name: _flatten(part) for name, part in _parts(state).items()}
    mngr = _manager(run_dir)
    mngr.save(int(step), args=ocp.args.StandardSave(tree), force=True)
    pending = PendingSave(mngr, int(step))
    if wait:
        pending.finish()
        return None
    return pending


def _step_dir(run_dir: str, step: int) -> str:
    return os.path.join(run_dir, CHECKPOINT_DIR, str(step))


def _damaged(run_dir: str, step: int, why) -> CheckpointError:
    steps = [s for s in checkpoint_steps(run_dir) if s != step]
    earlier = [s for s in steps if s < step]
    fallback = (f"delete {_step_dir(run_dir, step)} to go back to checkpoint {earlier[-1]}" if earlier
                else "start the run again without --resume (delete the run directory first)")
    if isinstance(why, BaseException):
        why = _short_reason(_root_cause(why))
    return CheckpointError(
        f"checkpoint {step} in {run_dir} is damaged or incomplete, its files cannot be read "
        f"({why}); {fallback}"
    )


_JSON_FILES = ("_CHECKPOINT_METADATA", os.path.join("default", "_METADATA"),
               os.path.join("default", "_sharding"), os.path.join("default", "array_metadatas", "process_0"))


def _check_files(run_dir: str, step: int) -> None:
    """Orbax's own small JSON files of a step must parse (a truncated one is otherwise only
    logged, or ends in a bare JSON error that names no file)."""
    for rel in _JSON_FILES:
        path = os.path.join(_step_dir(run_dir, step), rel)
        if not os.path.exists(path):
            if rel == _JSON_FILES[1]:
                raise _damaged(run_dir, step, f"{path} is missing")
            continue
        try:
            with open(path, encoding="utf-8") as f:
                json.load(f)
        except (OSError, UnicodeDecodeError, ValueError) as e:
            raise _damaged(run_dir, step, f"{path} is not valid JSON: {_first_line(e)}") from None


def _saved_tree(run_dir: str, step: int) -> dict:
    """{part: {leaf: metadata with .shape, .dtype}} of a checkpoint, from its metadata only."""
    _check_files(run_dir, step)
    _mute_closed_loop_callbacks()
    path = os.path.abspath(os.path.join(run_dir, CHECKPOINT_DIR))
    try:
        with _quiet():
            mngr = ocp.CheckpointManager(path, item_handlers=ocp.StandardCheckpointHandler())
            try:
                saved = getattr(mngr.item_metadata(step), "tree", None)
            finally:
                mngr.close()
    except Exception as e:  # orbax / tensorstore raise many types for unreadable files
        raise _damaged(run_dir, step, e) from None
    if not isinstance(saved, dict) or not all(isinstance(v, dict) for v in saved.values()):
        raise _damaged(run_dir, step, "its metadata does not list named parts of arrays: not a "
                                      "checkpoint written by vags_jax")
    return saved


def _open_step(run_dir: str, step: Optional[int]):
    if not os.path.isdir(run_dir):
        raise CheckpointError(f"run directory {run_dir!r} does not exist")
    if not os.path.isdir(os.path.join(run_dir, CHECKPOINT_DIR)):
        raise CheckpointError(f"no checkpoints in {run_dir!r}: train it first (python train.py --out {run_dir})")
    with _quiet():
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


def _check_fits(run_dir: str, step: int, want: dict, saved: Optional[dict] = None) -> None:
    """Compares the wanted {part: {leaf: ShapeDtypeStruct}} with the checkpoint's metadata (or
    the arrays ``read`` returned), so a checkpoint of another config is refused before orbax
    starts reading (a failed orbax read leaves coroutines behind that spam the interpreter's
    exit).  Parts of ``saved`` that are not wanted are ignored."""
    if saved is None:
        saved = _saved_tree(run_dir, step)
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
        f"different config (network, number of worlds, heightmap size or replay capacity) than "
        f"{os.path.join(run_dir, CONFIG_FILE)} describes ({_first_line(e)}). Use the run's own "
        f"config.json, or start a new run"
    )


def _abstract(tree: Any) -> dict[str, Any]:
    """``_flatten`` of a pytree of arrays or ShapeDtypeStructs -> {index: ShapeDtypeStruct}."""
    out = {}
    for i, x in enumerate(jax.tree.leaves(tree)):
        if jax.dtypes.issubdtype(getattr(x, "dtype", None), jax.dtypes.prng_key):
            x = jax.eval_shape(jax.random.key_data, x)
        if math.prod(np.shape(x) if not hasattr(x, "shape") else x.shape) > 0:
            out[f"{i:05d}"] = jax.ShapeDtypeStruct(tuple(x.shape), np.dtype(x.dtype))
    return out


def read(run_dir: str, step: Optional[int] = None, parts: Optional[list[str]] = None,
         saved: Optional[dict] = None):
    """The arrays of checkpoint ``step`` (default: the latest) as saved, as host NumPy arrays:
    ``({part: {leaf: ndarray}}, step)``; only ``parts`` when given.  Needs no target, so it can
    run before the state is built.  ``saved``: the step's metadata when the caller has read it
    (``_saved_tree``).  CheckpointError when there is no checkpoint or its files are damaged
    (naming the step directory and what to do)."""
    mngr, step = _open_step(run_dir, step)
    try:
        saved = _saved_tree(run_dir, step) if saved is None else saved
        names = list(saved) if parts is None else list(parts)
        missing = [n for n in names if n not in saved]
        if missing:
            raise _mismatch(run_dir, step, f"it has no part {missing[0]!r} (parts: {sorted(saved)})")
        want = {n: {k: jax.ShapeDtypeStruct(tuple(m.shape), np.dtype(m.dtype)) for k, m in saved[n].items()}
                for n in names}
        try:
            with _quiet():
                got = mngr.restore(step, args=ocp.args.PyTreeRestore(
                    item=want, restore_args=jax.tree.map(lambda _: ocp.RestoreArgs(restore_type=np.ndarray), want),
                    partial_restore=parts is not None))
        except Exception as e:  # orbax / tensorstore raise many types for unreadable files
            raise _damaged(run_dir, step, e) from None
    finally:
        mngr.close()
    out = {}
    for n, leaves in want.items():
        part = got.get(n) if isinstance(got, dict) else None
        if not isinstance(part, dict):
            raise _damaged(run_dir, step, f"part {n!r} came back empty")
        for k, v in leaves.items():
            a = part.get(k)
            if a is None or tuple(np.shape(a)) != v.shape or np.dtype(a.dtype) != v.dtype:
                raise _damaged(run_dir, step, f"part {n!r} leaf {k} does not match its metadata")
        out[n] = {k: np.asarray(part[k]) for k in leaves}
    return out, step


def fit(run_dir: str, step: int, target: Any, arrays: dict) -> Any:
    """Places ``read``'s arrays into the structure of ``target`` (a state dataclass / dict of
    pytrees, as for ``restore``), after checking every leaf's shape and dtype."""
    parts = _parts(target)
    want = {name: _abstract(p) for name, p in parts.items()}
    _check_fits(run_dir, step, want, saved={n: {k: jax.ShapeDtypeStruct(np.shape(a), np.dtype(a.dtype))
                                                  for k, a in leaves.items()} for n, leaves in arrays.items()})
    restored = {name: _unflatten(p, {k: jax.numpy.asarray(v) for k, v in arrays[name].items()})
                for name, p in parts.items()}
    if dataclasses.is_dataclass(target):
        return dataclasses.replace(target, **restored)
    return restored if isinstance(target, dict) else restored["state"]


def check_layout(run_dir: str, step: int, arrays: dict, want: dict) -> None:
    """Checks the parts named in ``want`` ({part: pytree of arrays or ShapeDtypeStructs}) against
    ``read``'s arrays: CheckpointError (another config) on any difference.  Lets a caller check
    the parts it can describe without building them, e.g. the learner from the network config."""
    _check_fits(run_dir, step, {n: _abstract(t) for n, t in want.items()},
                saved={n: {k: jax.ShapeDtypeStruct(np.shape(a), np.dtype(a.dtype)) for k, a in leaves.items()}
                       for n, leaves in arrays.items()})


def check_parts(run_dir: str, step: int, want: dict) -> None:
    """Checks the parts named in ``want`` ({part: pytree of arrays or ShapeDtypeStructs}) against
    checkpoint ``step``'s metadata, reading no array: CheckpointError (another config) on any
    difference.  Lets a caller refuse a checkpoint before anything is built or compiled."""
    mngr, step = _open_step(run_dir, step)
    mngr.close()
    _check_fits(run_dir, step, {n: _abstract(t) for n, t in want.items()})


def restore(run_dir: str, target: Any, step: Optional[int] = None) -> tuple[Any, int]:
    """Restores into the structure of ``target``; returns ``(state, step)``.

    Raises CheckpointError with what to fix when there is no checkpoint, its files are damaged
    or it does not fit (another config).  The metadata is compared first, so a checkpoint of
    another config is refused before its arrays are read.
    """
    mngr, step = _open_step(run_dir, step)
    mngr.close()
    want = {name: _abstract(p) for name, p in _parts(target).items()}
    _check_fits(run_dir, step, want)
    arrays, step = read(run_dir, step, parts=list(want))
    return fit(run_dir, step, target, arrays), step


def saved_parts(run_dir: str, step: int) -> list[str]:
    """The top-level part names of checkpoint ``step`` (from its metadata only)."""
    return sorted(_saved_tree(run_dir, step))


def part_shapes(run_dir: str, step: int, name: str) -> list[tuple]:
    """The shapes of part ``name``'s leaves in checkpoint ``step``, from its metadata alone."""
    return [tuple(m.shape) for m in _saved_tree(run_dir, step)[name].values()]


def restore_part(run_dir: str, name: str, target: Any, step: Optional[int] = None) -> tuple[Any, int]:
    """Restores only the top-level part ``name`` (e.g. "learner") into ``target``'s structure.
    Errors as for ``restore``."""
    got, step = restore_parts(run_dir, {name: target}, step)
    return got[name], step


def restore_parts(run_dir: str, targets: dict, step: Optional[int] = None,
                  optional: tuple = ()) -> tuple[dict, int]:
    """Several top-level parts at once, with one metadata read and one array read:
    ``{name: target}`` -> ``({name: tree}, step)``.  A ``None`` target returns the part as saved
    (``{leaf: ndarray}``, unchecked); a part in ``optional`` that the checkpoint lacks comes back
    None.  Errors as for ``restore``; every target is checked before any array is read."""
    mngr, step = _open_step(run_dir, step)
    mngr.close()
    saved = _saved_tree(run_dir, step)
    names = [n for n in targets if n in saved or n not in optional]
    _check_fits(run_dir, step, {n: _abstract(targets[n]) for n in names if targets[n] is not None}, saved)
    arrays, step = read(run_dir, step, parts=names, saved=saved)
    out = dict.fromkeys(targets)
    for n in names:
        # device_put transfers without compiling: jnp.asarray would compile (or load from the
        # compile cache) one small program per leaf shape.
        out[n] = arrays[n] if targets[n] is None else _unflatten(targets[n], jax.device_put(arrays[n]))
    return out, step


def tree_equal(a: Any, b: Any) -> bool:
    """Exact equality of two pytrees of arrays (for resume tests)."""
    la = [_leaf_to_array(x) for x in jax.tree.leaves(a)]
    lb = [_leaf_to_array(x) for x in jax.tree.leaves(b)]
    return len(la) == len(lb) and all(np.array_equal(np.asarray(x), np.asarray(y)) for x, y in zip(la, lb))
