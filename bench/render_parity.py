#!/usr/bin/env python3
"""Depth / heightmap agreement between the pure-JAX ray caster and MJX's Warp renderer (GPU).

    python bench/render_parity.py --worlds 64 --objects 10

Renders the same settled scenes from the global pose with both backends and prints the share of
pixels hit by both whose depth agrees within 1 mm, the share of hit/miss disagreements, and the
mean absolute heightmap difference.
"""
import argparse
import sys

import jax
import jax.numpy as jnp
import numpy as np

from vags_jax import config as C
from vags_jax import heightmap, render
from vags_jax.env import VagsEnv


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--worlds", type=int, default=64)
    p.add_argument("--objects", type=int, default=10)
    p.add_argument("--set", nargs="*", default=[])
    args = p.parse_args(argv)
    cfg = C.replace(C.Config(), **C.parse_overrides(args.set), **{"sim.impl": "warp"})
    env = VagsEnv(cfg)
    state = env.reset(jax.random.PRNGKey(0), np.full(args.worlds, args.objects))
    d = state.sim.data
    pose = jnp.broadcast_to(jnp.asarray(env.global_pose), (args.worlds, 4, 4))
    out = {}
    for backend in ("jax", "warp"):
        geo = render.prepare_geometry(env.scene.mj_model, env.scene.render_geom_mask, backend=backend,
                                      cam_cfg=cfg.camera, n_worlds=args.worlds)
        o = jax.jit(lambda xp, xm, rgb, ps: render.render_full(geo, xp, xm, rgb, ps, cfg.camera))(
            d.geom_xpos, d.geom_xmat, state.sim.geom_rgb, pose)
        hm = heightmap.heightmaps(o.depth, o.rgb, pose, cfg.camera, cfg.workspace)
        out[backend] = (np.asarray(o.depth), np.asarray(o.geom_id), np.asarray(hm[1]))
    (dj, gj, hj), (dw, gw, hw) = out["jax"], out["warp"]
    both = (dj > 0) & (dw > 0)
    within = np.abs(dj - dw)[both] <= 1e-3
    print(f"worlds {args.worlds}, {args.objects} objects, {cfg.camera.width}x{cfg.camera.height}")
    print(f"pixels hit by both: {both.mean():.4f}; depth within 1 mm: {within.mean():.4f}; "
          f"max |diff| {np.abs(dj - dw)[both].max() * 1000:.2f} mm")
    print(f"hit/miss disagreement: {((dj > 0) != (dw > 0)).mean():.5f}; same geom id: {(gj == gw)[both].mean():.4f}")
    print(f"heightmap mean |diff|: {np.abs(hj - hw).mean() * 1000:.3f} mm; cells differing > 2 mm: "
          f"{(np.abs(hj - hw) > 2e-3).mean():.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
