#!/usr/bin/env python3
"""GG-CNN training speed: Adam updates per second, side by side in one process.

    python bench/ggcnn_speed.py --batch 32 --size 300 --steps 50 --out runs/ggcnn_speed.json

Rows: the whole update of ``train.py --stage ggcnn`` (label maps drawn from 64 candidates per
view, rotation + zoom augmentation, forward, backward, Adam) with the transposed convolutions
computed phase by phase (``subpixel``, the default) and as flax's ``nn.ConvTranspose`` on the
dilated input (``dilated``); and the parts alone: label maps, augmentation, the gradient.
Random views and candidates (the speed does not depend on their values).  Timings are taken
after one warm-up call, over ``--steps`` calls, with ``block_until_ready``.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from vags_jax.config import GGCNNConfig  # noqa: E402
from vags_jax.ggcnn.labels import GraspCandidates, label_maps  # noqa: E402
from vags_jax.ggcnn.train import augment_batch, ggcnn_loss, init_train_state, make_optimizer, train_step  # noqa: E402
from vags_jax.nets.ggcnn import GGCNN  # noqa: E402


def timed(fn, args, steps):
    jax.block_until_ready(fn(*args))
    t0 = time.perf_counter()
    for _ in range(steps):
        out = fn(*args)
    jax.block_until_ready(out)
    return (time.perf_counter() - t0) / steps


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--batch", type=int, default=32)
    p.add_argument("--size", type=int, default=300)
    p.add_argument("--candidates", type=int, default=64)
    p.add_argument("--steps", type=int, default=50)
    p.add_argument("--out", default=None)
    a = p.parse_args(argv)
    B, K, P = a.batch, a.candidates, a.size
    rng = np.random.default_rng(0)
    cands = GraspCandidates(
        center=jnp.asarray(rng.uniform(0, P, (B, K, 2)), jnp.float32),
        angle=jnp.asarray(rng.uniform(-1.5, 1.5, (B, K)), jnp.float32),
        length=jnp.asarray(rng.uniform(20, 60, (B, K)), jnp.float32), jaw=jnp.full((B, K), 20.0),
        success=jnp.asarray(rng.uniform(size=(B, K)) < 0.45))
    x = jnp.asarray(rng.normal(size=(B, P, P)) * 0.01, jnp.float32)
    cfg = GGCNNConfig(input_size=P, batch_size=B)
    key = jax.random.PRNGKey(0)
    labels = jax.jit(lambda c: label_maps(c, P, P))(cands)
    rows = {"device": str(jax.devices()[0]), "batch": B, "size": P, "candidates": K, "steps": a.steps}
    rows["label_maps_s"] = timed(jax.jit(lambda c: label_maps(c, P, P)), (cands,), a.steps)
    rows["augment_s"] = timed(jax.jit(lambda k, x, l: augment_batch(k, x, l, cfg)), (key, x, labels), a.steps)
    opt = make_optimizer(cfg)
    for name, model in (("subpixel", GGCNN()), ("dilated", GGCNN(subpixel=False))):
        state = init_train_state(key, cfg, model, opt)
        grad = jax.jit(lambda p, x, l: jax.grad(lambda q: ggcnn_loss(q, model, x, l)[0])(p))
        rows[f"{name}_grad_s"] = timed(grad, (state.params, x, labels), a.steps)

        def update(state, key, x, c, model=model):
            return train_step(state, key, x, label_maps(c, P, P), model=model, optimizer=opt, cfg=cfg)

        rows[f"{name}_update_s"] = timed(jax.jit(update), (state, key, x, cands), a.steps)
        rows[f"{name}_updates_per_s"] = 1.0 / rows[f"{name}_update_s"]
    rows["speedup_update"] = rows["dilated_update_s"] / rows["subpixel_update_s"]
    print(json.dumps(rows, indent=1))
    if a.out:
        os.makedirs(os.path.dirname(os.path.abspath(a.out)), exist_ok=True)
        with open(a.out, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
