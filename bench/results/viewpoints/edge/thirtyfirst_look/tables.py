"""Prints the tables of bench/RESULTS.md, "Viewpoints that pay, thirty-first look": two new
`gpu-edge` pipelines (training seeds 14 and 15, ``o80/`` and ``o81/``; ``driver.sh``), evaluated
on the edge scenes, seeds 11-13, groups 1-10 x 50 rounds, as the ablation and VAGS with the
direct grasp planned by GDNet's argmax (``q/``, the preset) and by the success net's
half-turn-mean argmax (``success/``, ``vags.direct_score=success``, its own table); the tables'
bins; and the states of ``success/gate_states.npz``, each grasped three ways (GDNet's argmax,
the success net's argmax, after a move), paired.
Run from anywhere: python bench/results/viewpoints/edge/thirtyfirst_look/tables.py"""
import json
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.abspath(os.path.join(HERE, *[os.pardir] * 5))
sys.path[:0] = [os.path.join(REPO, "bench")]
from viewpoint_goals import pooled, read_report, row  # noqa: E402

TRAININGS = (("o80", 14), ("o81", 15))
SEEDS = (11, 12, 13)
POLICIES = (("ablation", "q", "eval_vags-no-viewpoint.json"),
            ("VAGS", "q", "eval_vags.json"),
            ("ablation", "success", "eval_vags-no-viewpoint.json"),
            ("VAGS", "success", "eval_vags.json"))


def report(run, planner, seed, file):
    return read_report(os.path.join(HERE, run, planner, f"seed{seed}", file))


def benchmark():
    print("| training seed | direct grasp planned by | policy | seed | success % | 6-10 success % | 6-10 clearing % | "
          "motion number | moves % | moves at 1 object % | picks/h | direct grasps % | after a move % |")
    print("|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for run, tseed in TRAININGS:
        for name, planner, file in POLICIES:
            for s in SEEDS:
                rep = report(run, planner, s, file)
                r, o = row(rep), rep["overall"]
                after = o.get("success_after_move")
                print(f"| {tseed} | {planner} | {name} | {s} | {100 * r['success']:.1f} | "
                      f"{100 * r['success_6_10']:.1f} | {100 * r['clearing_6_10']:.1f} | {r['motion_number']:.3f} | "
                      f"{100 * r['viewpoint']:.1f} | {100 * r['viewpoint_1']:.1f} | {r['picks_per_hour']:.0f} | "
                      f"{100 * o['success_direct']:.1f} | " + ("-" if after is None else f"{100 * after:.1f}") + " |")
    print("\n6-10 success, differences in points:")
    print("| training seed | seed | VAGS (q) over its ablation (q) | VAGS (q) over the ablation (success) | "
          "VAGS (success) over its ablation (success): the rule | ablation (success) over ablation (q) |")
    print("|---:|---:|---:|---:|---:|---:|")
    pays = True
    for run, tseed in TRAININGS:
        for s in SEEDS:
            p = [pooled(report(run, pl, s, f), 6, 10)[0] for _, pl, f in POLICIES]
            pays &= 100 * (p[3] - p[2]) >= 5.0
            print(f"| {tseed} | {s} | {100 * (p[1] - p[0]):+.1f} | {100 * (p[1] - p[2]):+.1f} | "
                  f"{100 * (p[3] - p[2]):+.1f} | {100 * (p[2] - p[0]):+.1f} |")
    print(f"\nThe rule (at least +5 on every seed of both trainings, the same planner on both sides): "
          f"{'met' if pays else 'not met'}")


def tables():
    for run, tseed in TRAININGS:
        for planner in ("q", "success"):
            with open(os.path.join(HERE, run, planner, "gate.json")) as f:
                t = json.load(f)
            moving = [k for k, v in enumerate(t["move_value"]) if v > 0]
            print(f"\ntraining seed {tseed}, {planner} table ({t['live_states']} states, GDNets {t['gdnet']} / "
                  f"after a move {t['close_gdnet']}): moves in bins {moving} of {len(t['move_value'])}, "
                  f"{3600 * t['rate']:.0f} picks/h")
            print("| bin | states | direct % | after a move % | move value |")
            print("|---:|---:|---:|---:|---:|")
            for k, (n, d, m, v) in enumerate(zip(t["states"], t["direct"], t["moved"], t["move_value"])):
                print(f"| {k} | {n} | {100 * d:.1f} | {100 * m:.1f} | {v:+.3f} |")


def mean_se(x):
    x = np.asarray(x, np.float64)
    return 100 * x.mean(), 100 * x.std(ddof=1) / np.sqrt(x.size)


def paired_states():
    print("\nThe success tables' states, each grasped three ways (the piles follow the success net's direct grasp):")
    print("| training seed | states | n | GDNet's argmax % | success net's argmax % | after a move % | "
          "success net - GDNet | after a move - success net |")
    print("|---:|---|---:|---:|---:|---:|---:|---:|")
    for run, tseed in TRAININGS:
        s = dict(np.load(os.path.join(HERE, run, "success", "gate_states.npz")))
        g, d, m = (s[k].astype(np.float64) for k in ("gdnet_success", "direct_success", "moved_success"))
        for label, sel in (("all", np.ones_like(g, bool)), ("1 object", s["objects"] == 1),
                           ("2-5 objects", (s["objects"] >= 2) & (s["objects"] <= 5)),
                           ("6-10 objects", s["objects"] >= 6),
                           ("lowest eighth of p_direct", s["p_direct"] < np.quantile(s["p_direct"], 0.125))):
            dg, md = mean_se(d[sel] - g[sel]), mean_se(m[sel] - d[sel])
            print(f"| {tseed} | {label} | {int(sel.sum())} | {100 * g[sel].mean():.1f} | {100 * d[sel].mean():.1f} | "
                  f"{100 * m[sel].mean():.1f} | {dg[0]:+.1f} +- {dg[1]:.1f} | {md[0]:+.1f} +- {md[1]:.1f} |")


if __name__ == "__main__":
    benchmark()
    tables()
    paired_states()
