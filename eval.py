#!/usr/bin/env python3
"""Benchmark a grasping policy (docs/benchmark.md): groups of k objects, R rounds each.

    python eval.py --run runs/tiny --groups 1,2,3 --rounds 4          # trained GDNet, greedy
    python eval.py --run runs/tiny --policy heuristic --groups 1-3    # scripted baseline, same config
    python eval.py --config tiny --policy random --groups 1,2 --rounds 8 --out runs/random.json
    python eval.py --run runs/gpu --set scene.max_objects=10 scene.copies_per_shape=2   # 1..10
    python eval.py --run runs/gpu --objects unseen      # held-out shapes the GDNet never saw

Policies: gdnet (needs --run: its config.json and latest checkpoint, or --step), random,
highest, heuristic (see vags_jax/evaluate.py).  The configuration is the run's config.json
(or the --config preset) with --set overrides applied; the scene must hold the largest group
(scene.max_objects).  Prints a Markdown table and writes the full report as JSON to --out, or
to RUN/eval_<policy>[_step<N>].json.
"""
from __future__ import annotations

import argparse
import os
import sys


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--run", default=None, help="run directory written by train.py (config.json + checkpoints/)")
    p.add_argument("--policy", default=None,
                   help="gdnet | random | highest | heuristic (default: gdnet with --run, else heuristic)")
    p.add_argument("--config", default=None, help="preset when there is no --run: tiny | gpu | paper | default (default: tiny)")
    p.add_argument("--set", nargs="*", default=[], metavar="SECTION.FIELD=VALUE",
                   help="evaluation config overrides, e.g. scene.max_objects=10 stage1.max_attempts_extra=5")
    p.add_argument("--groups", default="1-10", help="object counts: 1,2,3 or 1-10 or 1-3,5 (default 1-10)")
    p.add_argument("--rounds", type=int, default=50, help="rounds per group = parallel worlds (default 50)")
    p.add_argument("--seed", type=int, default=None, help="PRNG seed (default: the config's seed)")
    p.add_argument("--step", type=int, default=None, help="checkpoint step for gdnet (default: latest)")
    p.add_argument("--out", default=None, help="JSON report path (default: RUN/eval_<policy>.json)")
    p.add_argument("--speed", type=float, default=None, help="motion-time model: gripper speed m/s (default 0.5)")
    p.add_argument("--objects", default=None, choices=("train", "unseen", "legacy"),
                   help="object set of the scenes (default: the config's pool; 'unseen': the held-out "
                        "shapes, never trained on)")
    p.add_argument("--scenes", default=None, choices=("paper", "legacy"),
                   help="'legacy': the first benchmark's scenes (fixed blocks scattered apart, noiseless "
                        "camera from the old pose), for comparisons with earlier results")
    return p.parse_args(argv)


def parse_groups(text: str) -> list[int]:
    """"1,2,3" / "1-10" / "1-3,5" -> sorted unique ints."""
    out: list[int] = []
    try:
        for part in text.split(","):
            part = part.strip()
            if "-" in part:
                a, b = part.split("-", 1)
                a, b = int(a), int(b)
                if b < a:
                    raise ValueError
                out.extend(range(a, b + 1))
            else:
                out.append(int(part))
    except ValueError:
        raise ValueError(f"--groups {text!r}: expected object counts like 1,2,3 or 1-10") from None
    return sorted(set(out))


def main(argv=None) -> int:
    args = parse_args(argv)
    from vags_jax import checkpoint, config as C, evaluate as E

    policy = args.policy or ("gdnet" if args.run else "heuristic")
    try:
        if policy not in E.POLICIES:
            raise ValueError(f"unknown policy {policy!r}; choose one of {', '.join(E.POLICIES)}")
        if policy == "gdnet" and not args.run:
            raise ValueError("policy gdnet needs --run RUN_DIR (a run written by train.py)")
        if args.run and args.config:
            raise ValueError("--run uses the run's own config.json; drop --config (use --set to override)")
        if args.run and not os.path.isdir(args.run):
            raise checkpoint.CheckpointError(f"run directory {args.run!r} does not exist")
        groups = parse_groups(args.groups)
        variables, step = None, None
        if policy == "gdnet":
            run_cfg, variables, step = E.load_gdnet(args.run, args.step)
        elif args.run:
            run_cfg = checkpoint.load_config(args.run)
        else:
            run_cfg = C.preset(args.config or "tiny")
        scene_over = dict(C.LEGACY_SCENES) if args.scenes == "legacy" else {}
        if args.objects:
            scene_over.update({"scene.shapes": C.object_pool(args.objects, run_cfg.scene.pool_size),
                               "scene.copies_per_shape": 1})
        cfg = C.replace(run_cfg, **scene_over, **C.parse_overrides(args.set))
        if policy == "gdnet" and (cfg.net != run_cfg.net or cfg.workspace != run_cfg.workspace):
            raise ValueError("--set must not change net.* or workspace.*: the trained GDNet needs the "
                             "network and heightmaps it was trained with")
        groups = E.check_groups(groups, cfg, args.rounds)
        time_model = E.MotionTimeModel() if args.speed is None else E.MotionTimeModel(speed=args.speed)
    except ValueError as e:  # includes CheckpointError and config validation
        print(f"error: {e}", file=sys.stderr)
        return 2

    import jax

    out = args.out
    if out is None and args.run:
        tag = "".join(f"_{t}" for t in (args.objects, args.scenes) if t)
        out = os.path.join(args.run, f"eval_{policy}{tag}" + (f"_step{step}" if step is not None else "") + ".json")
    print(f"evaluating {policy}" + (f" ({args.run}, checkpoint {step})" if step is not None else "")
          + f": groups {groups}, {args.rounds} rounds each, impl={cfg.sim.impl}, devices={jax.devices()}",
          file=sys.stderr)
    ev = E.Evaluator(cfg)
    pol = E.make_policy(policy, cfg, variables)
    report = E.evaluate(cfg, pol, groups, args.rounds, args.seed, time_model, ev,
                        log=lambda s: print(s, file=sys.stderr, flush=True))
    print(E.format_table(report))
    if out:
        E.save_report(report, out, cfg, {"run": args.run, "checkpoint_step": step})
        print(f"wrote {out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
