#!/usr/bin/env python3
"""Do viewpoints pay?  Every grasp planner of VAGS executed from the SAME states.

For runs of today's presets (the "rate" gate, the grasp after a move planned by
``vags.close_score``) use ``bench/gate_headroom.py``: it plays the run's own planners and gate
on its gate table's states.  This script keeps the branches of the earlier looks (GDNet or
GG-CNN on the fused close view, the "success" and "q" gates' splits).

    python bench/viewpoint_states.py --run runs/vags --objects 6-10 --worlds 512 --steps 8 \
        --out bench/results/viewpoints/default/states_6-10.json

States: ``--worlds`` fresh piles of ``--objects`` objects, then every state of their rounds
for ``--steps`` attempts while GDNet grasps directly (greedy, from the global view).  From
each state the physics is branched (the simulator is pure: each branch starts from the same
``SimState``) and these grasps are executed, each in its own copy:

* ``direct``: GDNet's argmax on the global view (what VAGS does when it does not move);
* ``oracle``: GDNet's argmax on the ground-truth top-down maps (``vags_jax.perception.topdown``): the
  most any viewpoint policy could show GDNet;
* ``view_gdnet``: the camera moves to VANet's argmax viewpoint, GDNet grasps on the global
  maps fused with the close view (``vags.local_planner="gdnet"``);
* ``view_ggcnn``: the same move, GG-CNN grasps in the close image (the paper's planner; only
  with a GG-CNN in the run);
* ``random_gdnet``: as ``view_gdnet`` but the viewpoint is a uniformly random object cell
  (is VANet's choice better than chance?);
* ``grasp_gdnet``: as ``view_gdnet`` but the viewpoint is above GDNet's own argmax cell on the
  global view (a close look at the grasp it would make);
* ``relook_direct``: no move: a second global capture (fresh sensor noise) and GDNet's argmax on
  it (does a move pay more than a second look from the same pose?).

Reported per subset of states (all; where each gate -- ``success`` with either
``vags.view_estimate``, and ``q`` -- would grasp directly / move the camera): the success rate of each branch, and the AUROC with which each
gate score (the success net's p_direct, GDNet's largest Q) ranks the direct grasp's success,
and VANet's p_view the success after its move; also how much of the pile (the global map's
object cells) the close views of VANet's and of the random cell saw, and how often the two lead
to the same grasp (``view_footprint``).  Prints a Markdown table; ``--out`` JSON;
``--rows`` the per-state values (.npz, one array per branch and score) for analysis.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

BRANCHES = ("direct", "oracle", "view_gdnet", "view_ggcnn", "random_gdnet", "grasp_gdnet", "relook_direct")


def auroc(score, label):
    """Area under the ROC curve of ``score`` (N,) for binary ``label`` (N,) (ties count half);
    None when one class is empty."""
    import numpy as np

    score, label = np.asarray(score, np.float64), np.asarray(label, bool)
    pos, neg = score[label], score[~label]
    if pos.size == 0 or neg.size == 0:
        return None
    order = np.argsort(np.concatenate([pos, neg]), kind="mergesort")
    ranks = np.empty(order.size)
    allv = np.concatenate([pos, neg])[order]
    # Average ranks over ties.
    i = 0
    while i < allv.size:
        j = i
        while j + 1 < allv.size and allv[j + 1] == allv[i]:
            j += 1
        ranks[order[i:j + 1]] = 0.5 * (i + j) + 1
        i = j + 1
    return float((ranks[:pos.size].sum() - pos.size * (pos.size + 1) / 2) / (pos.size * neg.size))


SAME_GRASP_CELLS = 5  # two grasps within this many cells (1 cm at 2 mm) and of one rotation are "the same"


def view_footprint(height, close_view, close_rand, height_threshold: float) -> dict:
    """How much of the pile a close view covers, and whether VANet's viewpoint changes the grasp:
    height (B, H, W) the global map; close_view / close_rand the ``CloseView`` of VANet's and
    the random cell's moves -> {"seen_view", "seen_random"} (B,) the share of object cells
    (height > height_threshold) each close view saw, and "same_grasp" (B,) bool, the two fused-map
    grasps of one rotation within ``SAME_GRASP_CELLS`` cells of each other."""
    import jax.numpy as jnp

    obj = height > height_threshold
    n_obj = jnp.maximum(obj.sum(axis=(1, 2)), 1)
    share = lambda seen: (seen & obj).sum(axis=(1, 2)) / n_obj  # noqa: E731
    a, b = close_view.action, close_rand.action
    near = jnp.max(jnp.abs(a[:, 1:] - b[:, 1:]), axis=1) <= SAME_GRASP_CELLS
    return {"seen_view": share(close_view.seen), "seen_random": share(close_rand.seen),
            "same_grasp": near & (a[:, 0] == b[:, 0])}


def make_step(cfg, env, has_ggcnn: bool, has_mean: bool):
    """-> jitted ``(params, key, state) -> (next state, per-world dict)``."""
    import jax
    import jax.numpy as jnp

    from vags_jax.rl import exploration
    from vags_jax.config import replace
    from vags_jax.policies.decision import VagsNets, close_view_grasp, decide, gate_threshold, greedy, value_at
    from vags_jax.perception.topdown import TopDown

    nets, oracle = VagsNets(cfg), TopDown(env)
    cfg_gd = replace(cfg, **{"vags.local_planner": "gdnet"})
    cfg_gg = replace(cfg, **{"vags.local_planner": "ggcnn"})
    noisy = cfg.camera.noise.enabled

    def step(params, key, state):
        k_gd, k_gg, k_rand, k_rv, k_obs, k_gv, k_re = jax.random.split(key, 7)
        gdnet_q, close_q = nets.gdnet_q(params["gdnet"]), nets.close_q(params)
        q_grasp = gdnet_q(state.color, state.height)
        q_view = nets.q_fn(nets.vanet, params["vanet"])(state.color, state.height)
        q_success = nets.q_fn(nets.gdnet, params["success"])(state.color, state.height)
        thr_s = gate_threshold(dataclasses.replace(cfg.vags, gate="success"), None)
        d_s = decide(q_grasp, q_view, thr_s, q_success, "success", params["calibration"], "vanet")
        d_m = decide(q_grasp, q_view, thr_s, q_success, "success", params["calibration"], "mean") if has_mean else d_s
        d_q = decide(q_grasp, q_view, params["q_threshold"])
        pos, yaw = env.grasp_pose(state, d_q.grasp[:, 1:], d_q.grasp[:, 0])
        attempts = {"direct": env.direct_attempt(pos, yaw)}
        color_gt, height_gt = oracle.maps(state.sim)
        a_gt, _ = greedy(gdnet_q(color_gt, height_gt))
        pos, yaw = env.grasp_pose(state.replace(height=height_gt), a_gt[:, 1:], a_gt[:, 0])
        attempts["oracle"] = env.direct_attempt(pos, yaw)
        attempts["view_gdnet"], close_view = close_view_grasp(cfg_gd, env, state, d_q.view, k_gd, close_q)
        if has_ggcnn:
            attempts["view_ggcnn"], _ = close_view_grasp(cfg_gg, env, state, d_q.view, k_gg, None, params["ggcnn"],
                                                         nets.ggcnn)
        cell = jax.vmap(lambda k, h: exploration.random_object_cell(k, h, cfg.exploration))(
            jax.random.split(k_rand, state.n_worlds), state.height)
        rand_view = jnp.stack(jnp.unravel_index(cell, state.height.shape[1:]), -1).astype(jnp.int32)
        attempts["random_gdnet"], close_rand = close_view_grasp(cfg_gd, env, state, rand_view, k_rv, close_q)
        attempts["grasp_gdnet"], _ = close_view_grasp(cfg_gd, env, state, d_q.grasp[:, 1:], k_gv, close_q)
        again = env.with_observation(state, k_re)
        a_re, _ = greedy(gdnet_q(again.color, again.height))
        pos, yaw = env.grasp_pose(again, a_re[:, 1:], a_re[:, 0])
        attempts["relook_direct"] = env.direct_attempt(pos, yaw)
        out = {name: env.step_attempt(state, a, observe=False)[1].success for name, a in attempts.items()}
        out.update(q_max=d_q.q_max, p_direct=value_at(q_success, d_q.grasp),
                   p_view=jnp.max(q_view.reshape(q_view.shape[0], -1), axis=1),
                   direct_success_gate=d_s.direct, direct_mean_gate=d_m.direct, direct_q_gate=d_q.direct,
                   objects=env.n_remaining(state), live=(env.n_remaining(state) > 0) & ~state.sim.error,
                   **view_footprint(state.height, close_view, close_rand, cfg.exploration.height_threshold))
        nxt, _ = env.step_attempt(state, attempts["direct"], k_obs if noisy else None)
        return nxt, out

    return jax.jit(step)


def summarize(rows: dict, has_ggcnn: bool, has_mean: bool = False) -> dict:
    import numpy as np

    live = rows["live"]
    subsets = {"all": live,
               "success gate, VANet's estimate: direct": live & rows["direct_success_gate"],
               "success gate, VANet's estimate: move": live & ~rows["direct_success_gate"]}
    if has_mean:
        subsets.update({"success gate, mean after a move: direct": live & rows["direct_mean_gate"],
                        "success gate, mean after a move: move": live & ~rows["direct_mean_gate"]})
    subsets.update({"q gate: direct": live & rows["direct_q_gate"], "q gate: move": live & ~rows["direct_q_gate"]})
    out = {}
    for name, m in subsets.items():
        entry = {"states": int(m.sum())}
        for b in BRANCHES:
            if b == "view_ggcnn" and not has_ggcnn:
                continue
            entry[b] = float(rows[b][m].mean()) if m.any() else None
        entry["auroc_p_direct"] = auroc(rows["p_direct"][m], rows["direct"][m])
        entry["auroc_q_max"] = auroc(rows["q_max"][m], rows["direct"][m])
        entry["auroc_p_view"] = auroc(rows["p_view"][m], rows["view_gdnet"][m])
        entry["mean_p_direct"] = float(np.mean(rows["p_direct"][m])) if m.any() else None
        entry["mean_p_view"] = float(np.mean(rows["p_view"][m])) if m.any() else None
        for name_ in ("seen_view", "seen_random", "same_grasp"):  # absent in --rows files of older runs
            entry[name_] = float(np.mean(rows[name_][m])) if name_ in rows and m.any() else None
        out[name] = entry
    return out


def table(summary: dict, has_ggcnn: bool) -> str:
    cols = [b for b in BRANCHES if has_ggcnn or b != "view_ggcnn"]
    pct = lambda v: "-" if v is None else f"{100 * v:.1f}"  # noqa: E731
    num = lambda v: "-" if v is None else f"{v:.3f}"  # noqa: E731
    lines = ["| states | n | " + " | ".join(cols) + " | AUROC p_direct | AUROC Q | AUROC p_view | mean p_direct | mean p_view"
             " | pile seen, VANet's view % | pile seen, random view % | same grasp % |",
             "|---|---:|" + "---:|" * (len(cols) + 8)]
    for name, e in summary.items():
        lines.append(f"| {name} | {e['states']} | " + " | ".join(pct(e[c]) for c in cols) +
                     f" | {num(e['auroc_p_direct'])} | {num(e['auroc_q_max'])} | {num(e['auroc_p_view'])} | "
                     f"{num(e['mean_p_direct'])} | {num(e['mean_p_view'])} | {pct(e.get('seen_view'))} | "
                     f"{pct(e.get('seen_random'))} | {pct(e.get('same_grasp'))} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--run", required=True, help="train.py run directory with stage 2 or 3 networks")
    p.add_argument("--objects", default="6-10", help="MIN-MAX objects per pile (default 6-10)")
    p.add_argument("--worlds", type=int, default=256)
    p.add_argument("--steps", type=int, default=8, help="attempts per world (states measured per world)")
    p.add_argument("--seed", type=int, default=1234)
    p.add_argument("--scenes", default=None, choices=("edge", "legacy"),
                   help="a scene variant of eval.py --scenes (default: the run's scenes)")
    p.add_argument("--set", nargs="*", default=[], metavar="SECTION.FIELD=VALUE")
    p.add_argument("--out", default=None)
    p.add_argument("--rows", default=None, help="write the per-state values to this .npz")
    from vags_jax import cli
    cli.add_cache_dir(p)
    args = p.parse_args(argv)
    error = cli.use_compile_cache("viewpoint_states.py", args.cache_dir)
    if error is not None:
        return error

    import jax
    import numpy as np

    from vags_jax.stages import checkpoint, rundir as pipeline
    from vags_jax import config as C
    from vags_jax.env import VagsEnv

    lo, hi = (int(x) for x in args.objects.split("-"))
    variant = {"edge": C.EDGE_SCENES, "legacy": C.LEGACY_SCENES}.get(args.scenes, {})
    cfg = C.replace(checkpoint.load_config(args.run), **variant, **C.parse_overrides(args.set))
    if not 1 <= lo <= hi <= cfg.scene.max_objects:
        raise SystemExit(f"--objects {args.objects}: need 1 <= MIN <= MAX <= scene.max_objects = {cfg.scene.max_objects}")
    nets = pipeline.load_vags(args.run, cfg)
    if nets.success is None:
        raise SystemExit(f"{args.run} has no success net: train it with the current train.py")
    params = {"gdnet": nets.gdnet, "vanet": nets.vanet, "success": nets.success, "q_threshold": nets.q_threshold,
              "calibration": nets.calibration if nets.calibration is not None else np.zeros((2,), np.float32)}
    if nets.ggcnn is not None:
        params["ggcnn"] = nets.ggcnn
    if nets.close_gdnet is not None:  # the run grasps after a move with stage 3's GDNet ("split")
        params["close_gdnet"] = nets.close_gdnet
    env = VagsEnv(cfg)
    key = jax.random.PRNGKey(args.seed)
    k_n, k_reset, key = jax.random.split(key, 3)
    n_obj = np.asarray(jax.random.randint(k_n, (args.worlds,), lo, hi + 1))
    t0 = time.time()
    state = env.reset(k_reset, n_obj)
    env.prepare(args.worlds)
    has_mean = np.asarray(params["calibration"]).shape[0] >= 3
    step = make_step(cfg, env, nets.ggcnn is not None, has_mean)
    rows: dict[str, list] = {}
    for t in range(args.steps):
        key, k = jax.random.split(key)
        state, out = step(params, k, state)
        for name, v in jax.device_get(out).items():
            rows.setdefault(name, []).append(np.asarray(v))
        print(f"step {t + 1}/{args.steps}: {time.time() - t0:.0f} s", file=sys.stderr, flush=True)
    rows = {k: np.concatenate(v) for k, v in rows.items()}
    if args.rows:
        os.makedirs(os.path.dirname(os.path.abspath(args.rows)), exist_ok=True)
        np.savez_compressed(args.rows, **rows)
    summary = summarize(rows, nets.ggcnn is not None, has_mean)
    print(table(summary, nets.ggcnn is not None))
    if args.out:
        os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
        with open(args.out, "w") as f:
            json.dump({"run": args.run, "networks": nets.source, "scenes": args.scenes or "run's own",
                       "objects": args.objects, "worlds": args.worlds,
                       "steps": args.steps, "seed": args.seed, "move_cost": cfg.vags.move_cost,
                       "calibration": np.asarray(params["calibration"]).tolist(),
                       "q_threshold": float(nets.q_threshold), "summary": summary,
                       "wall_s": round(time.time() - t0, 1), "device": str(jax.devices()[0])}, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
