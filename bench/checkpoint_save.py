"""How long a stage's checkpoint holds up training on this device: a save waited for until its
files are written (every save but the last of a pipeline stage), against one left writing
(``checkpoint.save(wait=False)``: train.py's pipeline lets each stage's last checkpoint write
while the next stage starts, and waits for it only before its summary).

    python bench/checkpoint_save.py --config gpu --stages stage1,stage2 --dir /tmp/ck

The state saved is what dominates a stage's checkpoint: its replays at the config's capacity and
heightmap size (stage 1 one, GDNet's; stages 2 and 3 two, GDNet's and VANet's), filled with
random maps so that compression cannot shrink them below a real replay's size.  Prints one JSON
line per stage and repeat: bytes, ``wait_s`` (save waited for), ``return_s`` (save left writing:
until the arrays are off the device) and ``finish_s`` (the rest of its writing, waited for
afterwards).  Needs no physics (MuJoCo is not imported).
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import time

import jax
import jax.numpy as jnp

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from vags_jax import config as C  # noqa: E402
from vags_jax.rl import replay  # noqa: E402
from vags_jax.stages import checkpoint  # noqa: E402

ACTIONS = {"gdnet": 3, "vanet": 2}  # grasp (rotation, row, col) / viewpoint (row, col) per transition


def filled_replay(cfg, action_dim: int, key) -> replay.ReplayState:
    """A full replay of ``cfg.replay.capacity`` transitions of random maps (device arrays)."""
    H = cfg.workspace.heightmap_px
    color, height = jnp.zeros((H, H, 3), jnp.uint8), jnp.zeros((H, H), jnp.float32)
    buf = replay.init(cfg.replay.capacity, replay.make_grasp_transition(
        color, height, jnp.zeros((action_dim,), jnp.int32), 0.0, color, height, False))
    leaves, treedef = jax.tree.flatten(buf)
    keys = jax.random.split(key, len(leaves))

    def fill(x, k):
        if jnp.issubdtype(x.dtype, jnp.floating):
            return jax.random.uniform(k, x.shape, x.dtype)
        if x.dtype == jnp.bool_:
            return jax.random.bernoulli(k, 0.5, x.shape)
        return jax.random.randint(k, x.shape, 0, 255).astype(x.dtype)

    return jax.tree.unflatten(treedef, [fill(x, k) for x, k in zip(leaves, keys)])


def stage_state(cfg, name: str, key) -> dict:
    k1, k2 = jax.random.split(key)
    if name == "stage1":
        return {"replay": filled_replay(cfg, ACTIONS["gdnet"], k1)}
    return {"gdnet_replay": filled_replay(cfg, ACTIONS["gdnet"], k1),
            "vanet_replay": filled_replay(cfg, ACTIONS["vanet"], k2)}


def time_saves(state, where: str, step: int) -> dict:
    """One save waited for and one left writing, each into a fresh directory."""
    row = {}
    for mode in ("wait", "deferred"):
        d = os.path.join(where, mode)
        shutil.rmtree(d, ignore_errors=True)
        os.makedirs(d)
        t0 = time.time()
        pending = checkpoint.save(d, step, state, wait=(mode == "wait"))
        t1 = time.time()
        if mode == "wait":
            row["wait_s"] = round(t1 - t0, 2)
        else:
            row["return_s"] = round(t1 - t0, 2)
            row["finish_s"] = round(pending.finish(), 2)
        shutil.rmtree(d, ignore_errors=True)
    return row


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--config", default="gpu", help="preset (default: gpu)")
    p.add_argument("--set", nargs="*", default=[], metavar="SECTION.FIELD=VALUE", help="config overrides")
    p.add_argument("--stages", default="stage1,stage2", help="comma-separated: stage1 and/or stage2 (= stage3's size)")
    p.add_argument("--repeats", type=int, default=2)
    p.add_argument("--dir", default="/tmp/vags_checkpoint_bench", help="scratch directory (removed after)")
    args = p.parse_args(argv)
    cfg = C.replace(C.preset(args.config), **C.parse_overrides(args.set))
    for name in [s for s in args.stages.split(",") if s]:
        if name not in ("stage1", "stage2"):
            p.error(f"--stages takes stage1 and/or stage2, got {name!r}")
        state = stage_state(cfg, name, jax.random.PRNGKey(0))
        nbytes = sum(x.nbytes for x in jax.tree.leaves(state))
        jax.block_until_ready(state)
        for r in range(args.repeats):
            row = {"stage": name, "repeat": r, "bytes": nbytes, "device": str(jax.devices()[0]),
                   **time_saves(state, args.dir, 1 + r)}
            print(json.dumps(row), flush=True)
        del state
    shutil.rmtree(args.dir, ignore_errors=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
