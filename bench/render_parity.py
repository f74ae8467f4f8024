#!/usr/bin/env python3
"""Check that MJX's Warp renderer agrees with the pure-JAX ray caster (needs an NVIDIA GPU).

    python bench/render_parity.py --worlds 64 --objects 10

Renders the same settled scenes from the global pose with both backends, prints the agreement
and ONE verdict line, ``render parity: PASS`` or ``render parity: FAIL: <what failed>``, and
exits 0 on PASS, 1 on a mismatch, 2 when it cannot run (bad arguments, no warp-lang, no GPU).

Checks (thresholds below; figures measured on one H100 with 64 ten-object scenes at 640 x 480,
bench/RESULTS.md "eighth pass": 0.9998 / 0 / 0.9999 / 0.158 mm / 0.0018):
  * pixels hit by both renderers whose depth agrees within 1 mm: share >= 0.999 (the rest lie
    on silhouette edges, where one renderer's ray grazes past a corner the other one hits);
  * pixels hit by one renderer only: share <= 0.001;
  * pixels hit by both that see the same geom: share >= 0.999;
  * global heightmaps: mean |difference| <= 0.5 mm, share of cells off by more than 2 mm <= 0.01;
  * the sensor model's steep-face test: the share of hit pixels whose incidence is above
    ``camera.noise.grazing_dropout_deg``, under the Warp path's estimate (from depth and
    segmentation) against the ray caster's exact normals: ratio within 0.8 .. 1.25 (on CPU, with the
    ray caster's own depth and segmentation, bench/incidence_estimate.py measured 0.94; the
    estimate from depth alone gave 2.2).
"""
from __future__ import annotations

import argparse
import json
import os
import sys

# name -> (comparison, threshold, description); see the module docstring.
THRESHOLDS = {
    "depth_within_1mm": (">=", 0.999, "share of pixels hit by both with |depth diff| <= 1 mm"),
    "hit_miss_disagreement": ("<=", 0.001, "share of pixels hit by one renderer only"),
    "same_geom": (">=", 0.999, "share of pixels hit by both that see the same geom"),
    "heightmap_mean_abs_mm": ("<=", 0.5, "heightmap mean |diff| (mm)"),
    "heightmap_cells_over_2mm": ("<=", 0.01, "share of heightmap cells off by > 2 mm"),
}


# The sensor model's incidence (``steep_stats``); op "in" is a closed interval.
SENSOR_THRESHOLDS = {
    "steep_share_ratio": ("in", (0.8, 1.25), "share of steep-face pixels, Warp's estimate / exact"),
}


def steep_stats(cos_jax, depth_jax, cos_warp, depth_warp, grazing_deg: float) -> dict:
    """The steep-face test of the sensor model under each renderer's incidence.

    cos_*: (B, h, w) |cos incidence| (the ray caster's exact one; the Warp path's estimate);
    depth_*: (B, h, w) metres, 0 where nothing was hit.  Returns the share of each renderer's
    hit pixels seen at more than ``grazing_deg`` and their ratio (Warp / ray caster).
    """
    import numpy as np

    below = float(np.cos(np.deg2rad(grazing_deg)))
    shares = []
    for cos, depth in ((cos_jax, depth_jax), (cos_warp, depth_warp)):
        hit = np.asarray(depth) > 0
        shares.append(float((np.asarray(cos)[hit] < below).mean()) if hit.any() else 0.0)
    return {"steep_share_jax": shares[0], "steep_share_warp": shares[1],
            "steep_share_ratio": shares[1] / shares[0] if shares[0] > 0 else float("inf")}


def parity_stats(depth_jax, geom_jax, height_jax, depth_warp, geom_warp, height_warp, far: float = 2.0) -> dict:
    """Agreement of two renders of the same scenes.

    depth_*: (B, h, w) metres, 0 where nothing was hit; geom_*: (B, h, w) int geom ids;
    height_*: (B, H, W) global heightmaps (metres).  Returns plain floats (see ``THRESHOLDS``,
    plus ``hit_by_both`` and ``max_depth_diff_mm``).
    """
    import numpy as np

    dj, dw = np.asarray(depth_jax, np.float64), np.asarray(depth_warp, np.float64)
    hj, hw = np.asarray(height_jax, np.float64), np.asarray(height_warp, np.float64)
    both = (dj > 0) & (dw > 0)
    diff = np.abs(dj - dw)[both]
    hdiff = np.abs(hj - hw)
    n_both = int(both.sum())
    return {
        "hit_by_both": float(both.mean()),
        "depth_within_1mm": float((diff <= 1e-3).mean()) if n_both else 0.0,
        "max_depth_diff_mm": float(diff.max() * 1000) if n_both else float("nan"),
        # Only where the hit lies well inside the far clip: the ground plane at the top of an
        # oblique view reaches `far`, where one renderer clips a ray the other still hits.
        "hit_miss_disagreement": float((((dj > 0) != (dw > 0)) & (np.maximum(dj, dw) < 0.9 * far)).mean()),
        "same_geom": float((np.asarray(geom_jax) == np.asarray(geom_warp))[both].mean()) if n_both else 0.0,
        "heightmap_mean_abs_mm": float(hdiff.mean() * 1000),
        "heightmap_cells_over_2mm": float((hdiff > 2e-3).mean()),
    }


def failures(stats: dict, thresholds: dict = THRESHOLDS) -> list[str]:
    """The checks ``stats`` fails, one short phrase each (empty: PASS); ``thresholds``:
    ``THRESHOLDS`` (the renders) or ``SENSOR_THRESHOLDS`` (``steep_stats``)."""
    out = []
    if thresholds is THRESHOLDS and stats["hit_by_both"] == 0.0:
        out.append("no pixel was hit by both renderers")
    for name, (op, limit, what) in thresholds.items():
        value = stats[name]
        if op == "in":
            if not limit[0] <= value <= limit[1]:
                out.append(f"{what} {value:.5g} (needs {limit[0]:g} .. {limit[1]:g})")
            continue
        ok = value >= limit if op == ">=" else value <= limit
        if not ok:
            out.append(f"{what} {value:.5g} (needs {op} {limit:g})")
    return out


def warp_problem() -> str | None:
    """Why the Warp renderer cannot run here (one line), or None."""
    try:
        import warp
        import mujoco.mjx.warp  # noqa: F401  (MJX's Warp bindings)
    except ImportError as e:
        return (f"needs warp-lang and MJX's Warp backend ({e}); install them with "
                f"pip install -e '.[warp]' on a machine with an NVIDIA GPU")
    import jax

    if jax.default_backend() != "gpu" or not warp.is_cuda_available():
        return (f"needs an NVIDIA GPU: JAX runs on {jax.default_backend()!r} and warp sees "
                f"{'a' if warp.is_cuda_available() else 'no'} CUDA device; run it on a GPU machine")
    return None


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--worlds", type=int, default=64, help="scenes rendered (default 64)")
    p.add_argument("--objects", type=int, default=10, help="objects per scene (default 10)")
    p.add_argument("--set", nargs="*", default=[], metavar="SECTION.FIELD=VALUE", help="config overrides")
    p.add_argument("--out", default=None, help="also write the figures, thresholds and verdict as JSON here")
    args = p.parse_args(argv)
    if not 1 <= args.worlds <= 1024:  # both renderers hold every image at once
        p.error(f"--worlds must be in 1..1024, got {args.worlds}")
    return args


def build_config(args):
    """Config of the comparison (default config, --set overrides, physics impl "warp")."""
    from vags_jax import config as C

    cfg = C.replace(C.Config(), **C.parse_overrides(args.set), **{"sim.impl": "warp"})
    n = cfg.scene.max_objects
    if not 1 <= args.objects <= n:
        raise ValueError(f"--objects must be in 1..{n} (scene.max_objects = {n}), got {args.objects}")
    return cfg


def measure(cfg, worlds: int, objects: int) -> dict:
    """Render ``worlds`` settled scenes of ``objects`` objects with both backends -> parity_stats."""
    import jax
    import jax.numpy as jnp
    import numpy as np

    from vags_jax.perception import heightmap, render
    from vags_jax.env import VagsEnv

    env = VagsEnv(cfg)
    state = env.reset(jax.random.PRNGKey(0), np.full(worlds, objects))
    d = state.sim.data
    pose = jnp.broadcast_to(jnp.asarray(env.global_pose), (worlds, 4, 4))
    out = {}
    for backend in ("jax", "warp"):
        geo = render.prepare_geometry(env.scene.mj_model, env.scene.render_geom_mask, backend=backend,
                                      cam_cfg=cfg.camera, n_worlds=worlds)
        # Objects of drawn sizes: both renderers take the per-world geom sizes (exact depth;
        # the sensor model is not part of the comparison).
        o = jax.jit(lambda xp, xm, rgb, ps, sz: render.render_full(geo, xp, xm, rgb, ps, cfg.camera, geom_size=sz))(
            d.geom_xpos, d.geom_xmat, state.sim.geom_rgb, pose, env.sim.geom_size(state.sim))
        hm = heightmap.heightmaps(o.depth, o.rgb, pose, cfg.camera, cfg.workspace)
        out[backend] = (np.asarray(o.depth), np.asarray(o.geom_id), np.asarray(hm[1]), np.asarray(o.cos_incidence))
    (dj, gj, hj, cj), (dw, gw, hw, cw) = out["jax"], out["warp"]
    stats = parity_stats(dj, gj, hj, dw, gw, hw, cfg.camera.far)
    # The Warp path's incidence is its estimate from depth and segmentation (render_full).
    stats.update(steep_stats(cj, dj, cw, dw, cfg.camera.noise.grazing_dropout_deg))
    import mujoco

    names = {int(t): mujoco.mjtGeom(int(t)).name.replace("mjGEOM_", "").lower()
             for t in np.unique(env.scene.mj_model.geom_type)}
    stats.update(hit_miss_breakdown(dj, gj, dw, gw, np.asarray(env.scene.mj_model.geom_type), names, cfg.camera.far))
    return stats


def hit_miss_breakdown(depth_jax, geom_jax, depth_warp, geom_warp, geom_type, type_names: dict, far: float) -> dict:
    """Pixels hit by one renderer only, by the type of the geom that renderer hit: those the
    ``hit_miss_disagreement`` check counts (``hit_miss_by_geom_type``), and the count left out
    of it because the hit lies beyond 0.9 x ``far`` (``hit_miss_at_far_clip``).  Depths (B, H, W)
    metres (0 = miss), geom ids (B, H, W); ``geom_type`` (n_geoms,) int; ``type_names`` type ->
    name."""
    import numpy as np

    dj, dw = np.asarray(depth_jax), np.asarray(depth_warp)
    one = (dj > 0) != (dw > 0)
    near = np.maximum(dj, dw) < 0.9 * far
    seen = np.where(dj > 0, geom_jax, geom_warp)[one & near]
    types = np.asarray(geom_type)[np.maximum(seen, 0)]
    return {"hit_miss_by_geom_type": {type_names[int(t)]: int((types == t).sum()) for t in np.unique(types)},
            "hit_miss_at_far_clip": int((one & ~near).sum())}


def main(argv=None) -> int:
    args = parse_args(argv)
    try:
        cfg = build_config(args)
    except ValueError as e:
        print(f"render_parity.py: error: {e}", file=sys.stderr)
        return 2
    problem = warp_problem()
    if problem is not None:
        print(f"render_parity.py: error: the Warp renderer {problem}", file=sys.stderr)
        return 2

    stats = measure(cfg, args.worlds, args.objects)
    print(f"worlds {args.worlds}, {args.objects} objects, {cfg.camera.width}x{cfg.camera.height}")
    print(f"pixels hit by both: {stats['hit_by_both']:.4f}; depth within 1 mm: {stats['depth_within_1mm']:.4f}; "
          f"max |diff| {stats['max_depth_diff_mm']:.2f} mm")
    print(f"hit/miss disagreement: {stats['hit_miss_disagreement']:.5f}; same geom id: {stats['same_geom']:.4f}")
    print(f"heightmap mean |diff|: {stats['heightmap_mean_abs_mm']:.3f} mm; cells differing > 2 mm: "
          f"{stats['heightmap_cells_over_2mm']:.4f}")
    print(f"hit/miss disagreement pixels by the geom type hit: {stats['hit_miss_by_geom_type']}; "
          f"left out, beyond 0.9 x far: {stats['hit_miss_at_far_clip']}")
    print(f"steep-face pixels (sensor model): ray caster {100 * stats['steep_share_jax']:.3f} %, Warp's estimate "
          f"{100 * stats['steep_share_warp']:.3f} % (ratio {stats['steep_share_ratio']:.3f})")
    failed = failures(stats) + failures(stats, SENSOR_THRESHOLDS)
    print("render parity: PASS" if not failed else "render parity: FAIL: " + "; ".join(failed))
    if args.out:
        os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
        with open(args.out, "w") as f:
            json.dump({"worlds": args.worlds, "objects": args.objects, "set": args.set, **stats,
                       "thresholds": {k: [op, v] for k, (op, v, _) in (THRESHOLDS | SENSOR_THRESHOLDS).items()},
                       "failed": failed, "verdict": "PASS" if not failed else "FAIL"}, f, indent=1)
    return 0 if not failed else 1


if __name__ == "__main__":
    sys.exit(main())
