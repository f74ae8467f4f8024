#!/usr/bin/env python3
"""Where the time of one global observation goes: render vs heightmaps.

    python bench/observe_breakdown.py --renderer warp --worlds 1024 4096 --set camera.render_batch=1024

For each batch size, on settled 10-object scenes (``--objects``), times (median of --repeats
calls after a compiling one):
  * render      : ``render.render_full`` of one render group (min(worlds, render_batch) worlds):
                  depth, segmentation, colour and incidence;
  * render_raw  : (Warp renderer only) its own part of that: BVH refit + depth and
                  segmentation, without our colour / incidence post-processing;
  * heightmaps  : ``heightmap.heightmaps`` of those images (back-projection, scatter-max of
                  heights, colour of the highest point);
  * height_only : the same back-projection and the height scatter-max alone (no colour pass);
  * height_dump_cell : the same scatter with every missing / out-of-workspace point sent to
                  one shared dump cell, as ``heightmaps`` did before the seventh pass (now they
                  carry an out-of-range index and the scatter drops them);
  * observe     : ``VagsEnv.observe_global`` of all worlds (groups rendered one after another;
                  it colours only each heightmap cell's source pixel, not whole images);
  * warp_ffi_calls_in_observe : (Warp renderer only) how many MuJoCo Warp FFI calls the
                  compiled observe program holds.  Expected 2: one BVH refit and one render
                  (once per group when the groups run in a loop).  3 means XLA has cloned the
                  render into a fusion of its sliced inputs and kept the original, so every
                  group is rendered twice (see ``WarpGeometry.depth_and_segmentation``).
"""
from __future__ import annotations

import argparse
import re
import sys

import jax
import jax.numpy as jnp
import numpy as np

from timing import emit_row, timed
from vags_jax import config as C
from vags_jax.perception import heightmap, render
from vags_jax.env import VagsEnv


def height_only(depth, cam_pose, cam_cfg, ws_cfg):
    """The height half of ``heightmap.height_and_source``: (B, H, W) float32."""
    b, n_hm = depth.shape[0], ws_cfg.heightmap_px
    flat, h, _ = heightmap.point_cells(depth, cam_pose, cam_cfg, ws_cfg)
    return jnp.zeros(b * n_hm * n_hm).at[flat].max(h, mode="drop").reshape(b, n_hm, n_hm)


def height_dump_cell(depth, cam_pose, cam_cfg, ws_cfg):
    """`height_only` with the points that have no cell piled onto one extra (dump) cell."""
    b, n_hm = depth.shape[0], ws_cfg.heightmap_px
    flat, h, _ = heightmap.point_cells(depth, cam_pose, cam_cfg, ws_cfg)
    return jnp.zeros(b * n_hm * n_hm + 1).at[flat].max(h)[:-1].reshape(b, n_hm, n_hm)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--impl", default="jax", choices=["jax", "warp"])
    p.add_argument("--renderer", default="jax", choices=["jax", "warp"])
    p.add_argument("--worlds", nargs="+", type=int, default=[4])
    p.add_argument("--objects", type=int, default=10)
    p.add_argument("--config", default="default")
    p.add_argument("--set", nargs="*", default=[])
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--out", default=None, help="append the rows (JSON lines) here")
    args = p.parse_args(argv)
    cfg = C.replace(C.preset(args.config), **C.parse_overrides(args.set),
                    **{"sim.impl": args.impl, "camera.renderer": args.renderer})
    cam, ws = cfg.camera, cfg.workspace
    print(f"device: {jax.devices()[0].device_kind} ({jax.default_backend()}), jax {jax.__version__}", flush=True)
    env = VagsEnv(cfg)
    for b in args.worlds:
        env.prepare(b)
        state = env.reset(jax.random.PRNGKey(0), np.full(b, args.objects))
        g = min(b, cam.render_batch)
        d = state.sim.data
        pose = jnp.broadcast_to(jnp.asarray(env.global_pose), (g, 4, 4))
        xpos, xmat, rgb = d.geom_xpos[:g], d.geom_xmat[:g], state.sim.geom_rgb[:g]
        geometry = env.geometry(g)

        @jax.jit
        def render_fn(xpos, xmat, rgb, pose):
            out = render.render_full(geometry, xpos, xmat, rgb, pose, cam)
            return out.depth, out.rgb

        hm_fn = jax.jit(lambda dep, im, pose: heightmap.heightmaps(dep, im, pose, cam, ws))
        ho_fn = jax.jit(lambda dep, pose: height_only(dep, pose, cam, ws))
        hd_fn = jax.jit(lambda dep, pose: height_dump_cell(dep, pose, cam, ws))
        obs_fn = jax.jit(lambda s: env.observe_global(s, jax.random.PRNGKey(0)))  # key: sensor noise
        t_r, (depth, im) = timed(render_fn, xpos, xmat, rgb, pose, repeats=args.repeats)
        extra = {}
        if args.renderer == "warp":
            raw_fn = jax.jit(lambda xpos, xmat, pose: geometry.depth_and_segmentation(xpos, xmat, pose, cam))
            extra["render_raw_ms_per_group"] = 1e3 * timed(raw_fn, xpos, xmat, pose, repeats=args.repeats)[0]
        t_h, _ = timed(hm_fn, depth, im, pose, repeats=args.repeats)
        t_ho, _ = timed(ho_fn, depth, pose, repeats=args.repeats)
        t_hd, _ = timed(hd_fn, depth, pose, repeats=args.repeats)
        obs_compiled = obs_fn.lower(state.sim).compile()  # timed, and its program inspected
        t_o, _ = timed(obs_compiled, state.sim, repeats=args.repeats)
        if args.renderer == "warp":
            extra["warp_ffi_calls_in_observe"] = len(
                re.findall(r'custom_call_target="jax_callable[^"]*"', obs_compiled.as_text()))
        emit_row({
            "impl": args.impl, "renderer": args.renderer, "worlds": b, "render_group": g,
            "image": f"{cam.width}x{cam.height}", "heightmap": ws.heightmap_px, "overrides": args.set,
            "render_ms_per_group": 1e3 * t_r, **extra, "heightmaps_ms_per_group": 1e3 * t_h,
            "height_only_ms_per_group": 1e3 * t_ho, "height_dump_cell_ms_per_group": 1e3 * t_hd,
            "observe_ms_all_worlds": 1e3 * t_o,
            "observe_per_s": b / t_o, "render_share": t_r / (t_r + t_h),
        }, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
