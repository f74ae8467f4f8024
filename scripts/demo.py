"""See the pipeline work: batched scenes -> RGB-D -> heightmaps -> viewpoint -> scripted grasps.

    python scripts/demo.py --out runs/demo                 # tiny preset, 4 worlds, CPU ~2-3 min
    python scripts/demo.py --config default --worlds 2 --out runs/demo224

Writes PNGs into --out (heightmaps drawn as seen from above: +x to the right, +y UP, i.e. the
heightmap's rows flipped; camera images as the camera sees them):

  global_rgb.png / global_depth.png        the eye-in-hand camera at the preset global pose (depth
                                           through the sensor model: black = no depth returned)
  heightmap_color.png / heightmap_height.png  colour and height heightmaps of that view (heights:
                                           dark grey at table level, false colour above 1 cm)
  viewpoint_rgb.png / viewpoint_depth.png   re-render from ``camera.viewpoint_pose`` above each
                                           world's highest point (VANet's action), looking down
  viewpoint_heightmap.png                  per world: global height | viewpoint height | fused,
                                           with the occlusion shadow it filled in magenta
  grasps.png                               colour heightmap before each scripted grasp, the
                                           closing axis drawn (white = success, red = failure)

and prints, per world and attempt, the grasp (pixel, rotation), its outcome and the object.
Tiles are worlds 0..B-1 from left to right.
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np

from vags_jax import cli
from vags_jax.perception import camera, heightmap, render
from vags_jax import config as C
from vags_jax.benchmark import images
from vags_jax.env import VagsEnv
from vags_jax.policies.catalog import highest_act, min_width_grasp

MAGENTA = np.array([255, 0, 255], np.uint8)
TABLE_GREY = np.array([40, 40, 40], np.uint8)


def _up(img: np.ndarray, scale: int) -> np.ndarray:
    """Nearest-neighbour upscale of (H, W[, 3])."""
    return np.repeat(np.repeat(img, scale, axis=0), scale, axis=1)


def _hm_picture(img: np.ndarray, scale: int) -> np.ndarray:
    """Heightmap (rows = +y) -> picture seen from above (+y up), upscaled."""
    return _up(np.flipud(img), scale)


def _height_colours(h: np.ndarray, hmax: float, thr: float) -> np.ndarray:
    """(H, W) heights -> (H, W, 3) uint8: false colour above ``thr``, dark grey at table level
    (cells seen at table height and cells no point fell in alike)."""
    img = images.colorize(h, vmin=thr, vmax=hmax, zero_black=False)
    img[h <= thr] = TABLE_GREY
    return img


def _draw_axis(img: np.ndarray, pixel, theta: float, half_len_px: float, scale: int, colour) -> None:
    """Draws the closing axis through heightmap cell ``pixel`` on a ``_hm_picture`` in place."""
    H = img.shape[0] // scale
    r, c = (float(pixel[0]) + 0.5) * scale, (float(pixel[1]) + 0.5) * scale
    for t in np.linspace(-half_len_px * scale, half_len_px * scale, int(4 * half_len_px * scale) + 2):
        rr, cc = r + t * np.sin(theta), c + t * np.cos(theta)
        y, x = int(H * scale - 1 - rr), int(cc)  # rows flipped in the picture
        if 0 <= y < img.shape[0] and 0 <= x < img.shape[1]:
            img[max(0, y - 1): y + 1, max(0, x - 1): x + 1] = colour


def _say(*args) -> None:
    print(*args, flush=True)


def _describe(env: VagsEnv, sim_state, b: int) -> str:
    """World b's objects with their bounding boxes (cm) and whether each one rests on another."""
    aabb, _ = env.sim.object_bounds(sim_state.obj_size[b:b + 1])
    extents = 2 * np.asarray(aabb[0, :, 3:])
    bottom = np.asarray(env.sim.object_bottoms(sim_state)[b])
    out = []
    for i in np.flatnonzero(np.asarray(sim_state.active[b])):
        dims = "x".join(f"{100 * v:.1f}" for v in extents[i])
        out.append(f"{env.scene.shape_names[i]}#{i} ({dims} cm{' on top' if bottom[i] > 0.005 else ''})")
    return ", ".join(out)


# Long (one reason): a script's sequence of pictures, each a few lines.
def main(argv=None) -> int:
    p = cli.ArgumentParser(prog="demo.py", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", required=True, help="folder for the pictures")
    p.add_argument("--config", default="tiny", help="preset: tiny | gpu | paper | default (default: tiny)")
    p.add_argument("--set", nargs="*", default=[], metavar="SECTION.FIELD=VALUE", help="config overrides")
    p.add_argument("--worlds", type=int, default=4, help="parallel worlds (objects 1..max_objects, cycling)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--objects", type=int, default=None,
                   help="objects in every world (default: 1, 2, ... cycling up to scene.max_objects)")
    args = p.parse_args(argv)
    try:
        cfg = C.replace(C.preset(args.config), **C.parse_overrides(args.set))
        if args.worlds < 1:
            raise ValueError(f"--worlds must be >= 1, got {args.worlds}")
        if args.objects is not None and not 1 <= args.objects <= cfg.scene.max_objects:
            raise ValueError(f"--objects must be in 1..{cfg.scene.max_objects} (scene.max_objects), got {args.objects}")
        if os.path.exists(args.out) and not os.path.isdir(args.out):
            raise ValueError(f"--out {args.out!r} is a file; give a folder for the pictures")
        cli.check_parent_writable(os.path.join(args.out, "global_rgb.png"), "--out")
    except ValueError as e:
        return cli.fail("demo.py", e)
    os.makedirs(args.out, exist_ok=True)
    t0 = time.time()
    B, N, H = args.worlds, cfg.scene.max_objects, cfg.workspace.heightmap_px
    R = cfg.grasp.n_rotations
    scale = max(1, 256 // H)
    n_objects = np.array([args.objects or 1 + b % N for b in range(B)], np.int32)
    _say(f"demo: config {args.config}, {B} worlds with {n_objects.tolist()} objects, heightmap {H} px "
          f"({1000 * cfg.workspace.pixel_size:.1f} mm/px), camera {cfg.camera.width}x{cfg.camera.height}, "
          f"impl={cfg.sim.impl}")

    env = VagsEnv(cfg)
    key = jax.random.PRNGKey(args.seed)
    k_reset, k_grasp = jax.random.split(key)
    state = env.reset(k_reset, n_objects)
    _say(f"[{time.time() - t0:5.1f} s] reset: objects dropped and settled")
    for b in range(B):
        _say(f"  world {b}: {_describe(env, state.sim, b)}")

    geometry = env.geometry(B)

    @jax.jit
    def views(sim_state, poses, key):
        """Render every world from poses (B, 4, 4) through the sensor model (``camera.noise``)
        -> depth (0 = the sensor's holes), rgb, colour and height heightmaps."""
        d = sim_state.data
        out = render.render_full(geometry, d.geom_xpos, d.geom_xmat, sim_state.geom_rgb, poses, cfg.camera,
                                 geom_size=env.sim.geom_size(sim_state))
        depth = render.add_depth_noise(key, out.depth, out.cos_incidence, cfg.camera.noise, cfg.camera.fx)
        col, hgt = heightmap.heightmaps(depth, out.rgb, poses, cfg.camera, cfg.workspace)
        return depth, out.rgb, col, hgt

    # ---- global view
    g_pose = jnp.broadcast_to(jnp.asarray(env.global_pose), (B, 4, 4))
    k_view = jax.random.fold_in(key, 7)
    depth, rgb, col, hgt = jax.device_get(views(state.sim, g_pose, k_view))
    images.save_png(os.path.join(args.out, "global_rgb.png"), images.tile(list(rgb), cols=B))
    dmax = float(depth.max()) or 1.0
    images.save_png(os.path.join(args.out, "global_depth.png"),
                    images.tile([images.colorize(d, vmin=cfg.camera.near, vmax=dmax) for d in depth], cols=B))
    images.save_png(os.path.join(args.out, "heightmap_color.png"),
                    images.tile([_hm_picture(c, scale) for c in col], cols=B))
    hmax = max(float(hgt.max()), 0.02)
    thr = cfg.exploration.height_threshold
    images.save_png(os.path.join(args.out, "heightmap_height.png"),
                    images.tile([_hm_picture(_height_colours(h, hmax, thr), scale) for h in hgt], cols=B))
    _say(f"[{time.time() - t0:5.1f} s] global view rendered: heights up to {100 * hgt.max():.1f} cm, "
          f"object cells per world {(hgt > cfg.exploration.height_threshold).sum(axis=(1, 2)).tolist()}, "
          f"sensor holes {np.round(100 * (depth == 0).mean(axis=(1, 2)), 1).tolist()} % of pixels "
          f"(sensor model {'on' if cfg.camera.noise.enabled else 'off'})")

    # ---- viewpoint above each world's highest point (what VANet's action does)
    highest = jax.jit(highest_act(cfg))
    min_width = jax.jit(lambda hm: min_width_grasp(hm, cfg)[0])
    vp_pixel = np.asarray(highest(None, None, state))[:, 1:]
    vp_pose = camera.viewpoint_pose(jnp.asarray(vp_pixel), jnp.asarray(hgt), cfg.workspace, cfg.camera)
    vdepth, vrgb, vcol, vhgt = jax.device_get(views(state.sim, vp_pose, jax.random.fold_in(k_view, 1)))
    images.save_png(os.path.join(args.out, "viewpoint_rgb.png"), images.tile(list(vrgb), cols=B))
    images.save_png(os.path.join(args.out, "viewpoint_depth.png"),
                    images.tile([images.colorize(d, vmin=cfg.camera.near) for d in vdepth], cols=B))
    fused = np.maximum(hgt, vhgt)
    filled = (hgt <= thr) & (vhgt > thr)  # object cells the global view had in its shadow
    tiles = []
    for b in range(B):
        row = [_height_colours(hgt[b], hmax, thr), _height_colours(vhgt[b], hmax, thr)]
        f = _height_colours(fused[b], hmax, thr)
        f[filled[b]] = MAGENTA
        tiles.extend(_hm_picture(x, scale) for x in row + [f])
    images.save_png(os.path.join(args.out, "viewpoint_heightmap.png"), images.tile(tiles, cols=3))
    _say(f"[{time.time() - t0:5.1f} s] viewpoints at pixels {vp_pixel.tolist()} "
          f"(camera {cfg.camera.viewpoint_height:.2f} m above the surface): object cells hidden from the "
          f"global view and seen from the viewpoint, per world: {filled.sum(axis=(1, 2)).tolist()}")

    # ---- scripted grasps: highest point at 0 deg, the same at 90 deg, then min-width
    half_len = cfg.grasp.finger_stroke / 2 / cfg.workspace.pixel_size
    plans = [("highest point, rotation 0", lambda s: np.asarray(highest(None, None, s))),
             (f"highest point, rotation {R // 4} (90 deg)",
              lambda s: np.asarray(highest(None, None, s)) + np.array([R // 4, 0, 0])),
             ("min-width heuristic", lambda s: np.asarray(min_width(s.height)))]
    grasp_tiles = []
    for i, (name, plan) in enumerate(plans):
        action = plan(state).astype(np.int32)
        before = np.asarray(state.color)
        active_before = np.asarray(state.sim.active)
        state, res = env.grasp(state, action[:, 1:], action[:, 0], jax.random.fold_in(k_grasp, i)
                               if cfg.camera.noise.enabled else None)
        res = jax.device_get(res)
        remaining = np.asarray(env.n_remaining(state))
        _say(f"[{time.time() - t0:5.1f} s] grasp {i + 1}: {name}")
        for b in range(B):
            obj = int(res.object[b])
            what = (f"grasped {env.scene.shape_names[obj]}#{obj}" if res.success[b]
                    else ("failed" if active_before[b].any() else "failed (table already clear)"))
            xy = np.asarray(camera.pixel_to_world_xy(action[b, 1:], cfg.workspace))
            _say(f"  world {b}: pixel (row {action[b, 1]:3d}, col {action[b, 2]:3d}) = "
                  f"({100 * xy[0]:+5.1f}, {100 * xy[1]:+5.1f}) cm, rotation {action[b, 0]:2d} "
                  f"({np.degrees(action[b, 0] * cfg.grasp.rotation_step):5.1f} deg): {what}; "
                  f"pad gap {1000 * res.gripper_gap[b]:4.1f} mm; {remaining[b]} object(s) left")
            pic = _hm_picture(before[b], scale)
            _draw_axis(pic, action[b, 1:], float(action[b, 0] * cfg.grasp.rotation_step), half_len, scale,
                       (255, 255, 255) if res.success[b] else (255, 0, 0))
            grasp_tiles.append(pic)
    images.save_png(os.path.join(args.out, "grasps.png"), images.tile(grasp_tiles, cols=B))
    _say(f"[{time.time() - t0:5.1f} s] attempts {np.asarray(state.attempts).tolist()}, successes "
          f"{np.asarray(state.successes).tolist()}, travel {np.round(np.asarray(state.travel), 2).tolist()} m "
          f"per world; pictures in {args.out}/ (grasps.png: one row per attempt)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
