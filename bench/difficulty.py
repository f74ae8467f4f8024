#!/usr/bin/env python3
"""How hard is the benchmark?  Several policies on several object sets, in one process.

    python bench/difficulty.py --config gpu --groups 1-10 --rounds 50 --out-dir bench/results/difficulty
    python bench/difficulty.py --run runs/gdnet --policies random,heuristic,gdnet --objects train,unseen

For each object set (``train``: the default scenes; ``unseen``: the held-out shapes; ``legacy``:
the first benchmark's fixed blocks on its scenes, see ``config.LEGACY_SCENES``) and policy
(``random``, ``highest``, ``heuristic``, and ``gdnet`` with ``--run``), runs the benchmark
(``vags_jax.benchmark.protocol``: groups of k objects, R rounds each, the same seeds for every policy),
prints each table and then one summary row per (objects, policy): grasp success over all
groups, success, clearing and motion number at the largest group.  Writes every report as JSON
into ``--out-dir`` (``<objects>_<policy>.json``) and the summary as ``summary.json``.
One Evaluator (one compiled environment) per object set, shared by its policies.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--config", default=None, help="preset when there is no --run (default: gpu)")
    p.add_argument("--run", default=None, help="train.py run directory: its config, and its GDNet for 'gdnet'")
    p.add_argument("--policies", default="random,heuristic", help="comma list: random, highest, heuristic, gdnet")
    p.add_argument("--objects", default="train", help="comma list of object sets: train, unseen, legacy")
    p.add_argument("--groups", default="1-10")
    p.add_argument("--rounds", type=int, default=50)
    p.add_argument("--seed", type=int, default=None)
    p.add_argument("--set", nargs="*", default=[], metavar="SECTION.FIELD=VALUE")
    p.add_argument("--out-dir", default=None)
    args = p.parse_args(argv)

    from vags_jax.benchmark.requests import parse_groups
    from vags_jax.stages import checkpoint
    from vags_jax import config as C
    from vags_jax.benchmark import protocol as E
    from vags_jax.benchmark import metrics as M
    from vags_jax.policies import catalog as P
    from vags_jax.stages import rundir

    try:
        policies = [x.strip() for x in args.policies.split(",") if x.strip()]
        sets = [x.strip() for x in args.objects.split(",") if x.strip()]
        for x in policies:
            if x not in P.POLICIES:
                raise ValueError(f"unknown policy {x!r}; choose from {', '.join(P.POLICIES)}")
        for x in sets:
            if x not in C.OBJECT_SETS:
                raise ValueError(f"unknown object set {x!r}; choose from {', '.join(C.OBJECT_SETS)}")
        if "gdnet" in policies and not args.run:
            raise ValueError("policy gdnet needs --run")
        variables = None
        if args.run:
            if "gdnet" in policies:
                base, variables, _ = rundir.load_gdnet(args.run)
            else:
                base = checkpoint.load_config(args.run)
        else:
            base = C.preset("gpu" if args.config is None else args.config)
        groups = parse_groups(args.groups)
    except ValueError as e:
        print(f"difficulty.py: error: {e}", file=sys.stderr)
        return 2

    summary = []
    for objects in sets:
        over = dict(C.LEGACY_SCENES) if objects == "legacy" else {
            "scene.shapes": C.object_pool(objects, base.scene.pool_size), "scene.copies_per_shape": 1}
        cfg = C.replace(base, **over, **C.parse_overrides(args.set))
        gr = E.check_groups(groups, cfg, args.rounds)
        ev = E.Evaluator(cfg)
        for policy in policies:
            t0 = time.time()
            pol = P.make_policy(policy, cfg, variables)
            report = E.evaluate(cfg, pol, gr, args.rounds, args.seed, M.MotionTimeModel(), ev,
                                log=lambda s: print(s, file=sys.stderr, flush=True))
            print(f"\n### objects {objects}, policy {policy} ({time.time() - t0:.0f} s)\n")
            print(M.format_table(report), flush=True)
            last = report["groups_metrics"][-1]  # the largest group
            summary.append({"objects": objects, "policy": policy,
                            "success": report["overall"]["grasp_success_rate"],
                            "largest_group": last["n_objects"], "success_largest": last["grasp_success_rate"],
                            "clearing_largest": last["clearing_rate"], "motions_largest": last["motion_number"],
                            "seconds": time.time() - t0})
            if args.out_dir:
                M.save_report(report, os.path.join(args.out_dir, f"{objects}_{policy}.json"), cfg,
                              {"run": args.run})
    print("\n| objects | policy | success, all groups % | success at largest % | clearing at largest % | motions at largest |")
    print("|---|---|---:|---:|---:|---:|")
    for r in summary:
        pct = lambda v: "-" if v is None else f"{100 * v:.1f}"  # noqa: E731
        print(f"| {r['objects']} | {r['policy']} | {pct(r['success'])} | {pct(r['success_largest'])} | "
              f"{pct(r['clearing_largest'])} | {r['motions_largest'] if r['motions_largest'] is None else round(r['motions_largest'], 2)} |")
    if args.out_dir:
        with open(os.path.join(args.out_dir, "summary.json"), "w") as f:
            json.dump(summary, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
