#!/usr/bin/env python3
"""The sensor model under the Warp renderer's estimated incidence against the ray caster's exact one.

    python bench/incidence_estimate.py --config tiny --worlds 16 --out runs/incidence.json    # CPU, a minute
    python bench/incidence_estimate.py --config gpu --set sim.impl=jax --worlds 8 --objects 10
    python bench/incidence_estimate.py --config tiny --view close       # above each pile's highest cell

The depth sensor model drops pixels seen at a grazing incidence (``camera.noise``), and colours are
shaded by the incidence.  The ray caster ("jax") gives each pixel's exact surface normal; MJX's
Warp renderer gives none, so its path estimates the incidence from the depth image by finite
differences (``render.normals_from_depth``).  This script measures that estimate on settled scenes
of the config, from the global view or (``--view close``) from a close viewpoint above each
pile's highest heightmap cell, with the ray caster alone (so it runs on any device: the estimate
needs only depth and segmentation, which both renderers give alike, bench/render_parity.py):

* ``exact``: the ray caster's normals (the "jax" path);
* ``depth``: differences over all four neighbours, as the Warp path did before it passed the
  segmentation (across an object's silhouette they see a depth jump);
* ``segmentation``: differences over neighbours on the same geom only (the Warp path now).

For each: the share of hit pixels dropped as steep faces, the steep decisions that differ from
``exact``, the mean |cos| error; then the whole sensor model with the same noise draws, and its
heightmaps: the share of cells no pixel reached (holes), the cells more than 2 mm from the
``exact`` heightmap, and the mean colour difference.  Prints a Markdown table; --out writes JSON.
"""
from __future__ import annotations

import argparse
import json
import os
import sys

ESTIMATES = ("exact", "depth", "segmentation")


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--config", default="tiny", help="preset (default tiny)")
    p.add_argument("--set", nargs="*", default=[], metavar="SECTION.FIELD=VALUE", help="config overrides")
    p.add_argument("--worlds", type=int, default=16, help="scenes (default 16)")
    p.add_argument("--objects", type=int, default=None, help="objects per scene (default scene.max_objects)")
    p.add_argument("--view", default="global", choices=("global", "close"),
                   help="the global view, or a close view above each pile's highest cell")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", default=None, help="JSON file for every figure")
    args = p.parse_args(argv)
    if not 1 <= args.worlds <= 256:
        p.error(f"--worlds must be in 1..256, got {args.worlds}")
    return args


def build_config(args):
    from vags_jax import config as C

    cfg = C.replace(C.preset(args.config), **C.parse_overrides(args.set), **{"camera.renderer": "jax"})
    n = cfg.scene.max_objects
    objects = n if args.objects is None else args.objects
    if not 1 <= objects <= n:
        raise ValueError(f"--objects must be in 1..{n} (scene.max_objects = {n}), got {objects}")
    if not cfg.camera.noise.enabled:
        raise ValueError("camera.noise.enabled is false: the sensor model, which the incidence feeds, is off")
    return cfg, objects


def summarise(exact_cos, cos, hit, steep_below, sensor_depth, exact_sensor_depth, height, source, exact_height,
              colour, exact_colour) -> dict:
    """Figures of one incidence estimate against ``exact`` (plain floats; arrays as named)."""
    import numpy as np

    h = hit.astype(bool)
    return {
        "steep_share": float((cos < steep_below)[h].mean()),
        "steep_decisions_differing": float(((cos < steep_below) != (exact_cos < steep_below))[h].mean()),
        "mean_abs_cos_error": float(np.abs(cos - exact_cos)[h].mean()),
        "image_holes": float((sensor_depth == 0)[h].mean()),
        "image_pixels_differing": float((sensor_depth != exact_sensor_depth)[h].mean()),
        "heightmap_holes": float((source < 0).mean()),
        "heightmap_cells_over_2mm": float((np.abs(height - exact_height) > 2e-3).mean()),
        "heightmap_mean_abs_colour": float(np.abs(colour.astype(np.int32) - exact_colour.astype(np.int32)).mean()),
    }


def measure(cfg, worlds: int, objects: int, seed: int, view: str = "global") -> dict:
    import jax
    import jax.numpy as jnp
    import numpy as np

    from vags_jax.env import VagsEnv
    from vags_jax.perception import heightmap, render

    env = VagsEnv(cfg)
    key_reset, key_noise = jax.random.split(jax.random.PRNGKey(seed))
    state = env.reset(key_reset, np.full(worlds, objects))
    d = state.sim.data
    pose = env.global_poses(worlds)
    if view == "close":  # above the highest cell of the global heightmap (the top of the pile)
        top = jnp.argmax(state.height.reshape(worlds, -1), axis=1)
        n = state.height.shape[-1]
        pose = env.viewpoint_pose(state, jnp.stack([top // n, top % n], axis=1))
    geometry = render.prepare_geometry(env.scene.mj_model, env.scene.render_geom_mask)
    cam, ws, noise = cfg.camera, cfg.workspace, cfg.camera.noise
    keys = jax.random.split(key_noise, worlds)

    @jax.jit
    def observe_all(xpos, xmat, rgb, size):
        depth, gid, exact = render.depth_and_segmentation(geometry, xpos, xmat, pose, cam, geom_size=size)
        cos = {"exact": exact, "depth": render.normals_from_depth(depth, cam),
               "segmentation": render.normals_from_depth(depth, cam, gid)}
        out = {}
        for name, c in cos.items():
            sensor = jax.vmap(lambda k, dd, cc: render.add_depth_noise(k, dd[None], cc[None], noise, cam.fx)[0])(
                keys, depth, c)
            height, source = heightmap.height_and_source(sensor, pose, cam, ws)
            b = depth.shape[0]
            pix = jnp.maximum(source.reshape(b, -1), 0)
            g = jnp.where(source.reshape(b, -1) >= 0, jnp.take_along_axis(gid.reshape(b, -1), pix, axis=1), -1)
            colour = render.shade(g, jnp.take_along_axis(c.reshape(b, -1), pix, axis=1), rgb)
            out[name] = (c, sensor, height, source, colour)
        return depth, out

    size = env.sim.geom_size(state.sim)
    depth, out = jax.tree.map(np.asarray, observe_all(d.geom_xpos, d.geom_xmat, state.sim.geom_rgb, size))
    steep_below = float(np.cos(np.deg2rad(noise.grazing_dropout_deg)))
    hit = depth > 0
    ex = out["exact"]
    figures = {name: summarise(ex[0], c, hit, steep_below, sensor, ex[1], height, source, ex[2], colour, ex[4])
               for name, (c, sensor, height, source, colour) in out.items()}
    return {"hit_share": float(hit.mean()), "figures": figures}


COLUMNS = (("steep_share", "steep pixels %", 100), ("steep_decisions_differing", "steep decisions unlike exact %", 100),
           ("mean_abs_cos_error", "mean abs cos error", 1), ("image_holes", "image holes %", 100),
           ("image_pixels_differing", "sensor pixels unlike exact %", 100), ("heightmap_holes", "heightmap holes %", 100),
           ("heightmap_cells_over_2mm", "cells > 2 mm from exact %", 100),
           ("heightmap_mean_abs_colour", "mean abs colour diff", 1))


def table(result: dict) -> str:
    lines = ["| incidence | " + " | ".join(c[1] for c in COLUMNS) + " |", "|---|" + "---:|" * len(COLUMNS)]
    for name in ESTIMATES:
        f = result["figures"][name]
        lines.append(f"| {name} | " + " | ".join(f"{f[k] * scale:.4g}" for k, _, scale in COLUMNS) + " |")
    return "\n".join(lines)


def main(argv=None) -> int:
    args = parse_args(argv)
    try:
        cfg, objects = build_config(args)
    except ValueError as e:
        print(f"incidence_estimate.py: error: {e}", file=sys.stderr)
        return 2
    result = measure(cfg, args.worlds, objects, args.seed, args.view)
    print(f"{args.worlds} scenes of {objects} objects, {args.view} view ({args.config}, {cfg.camera.width} x {cfg.camera.height} px, "
          f"heightmaps {cfg.workspace.heightmap_px} px); {100 * result['hit_share']:.1f} % of pixels hit")
    print(table(result))
    if args.out:
        os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
        with open(args.out, "w") as f:
            json.dump({"config": args.config, "set": args.set, "worlds": args.worlds, "objects": objects,
                       "seed": args.seed, "view": args.view, **result}, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
