#!/usr/bin/env python3
"""Benchmark a grasping policy (docs/benchmark.md): groups of k objects, R rounds each.

    python eval.py --run runs/tiny --groups 1,2,3 --rounds 4          # trained GDNet, greedy
    python eval.py --run runs/tiny --policy heuristic --groups 1-3    # scripted baseline, same config
    python eval.py --config tiny --policy random --groups 1,2 --rounds 8 --out runs/random.json
    python eval.py --run runs/gpu --set scene.max_objects=10 scene.copies_per_shape=2   # 1..10
    python eval.py --run runs/gpu --objects unseen      # held-out shapes the GDNet never saw
    python eval.py --run runs/gpu --policy ggcnn-close  # GG-CNN of train.py --stage ggcnn, close view

Policies: gdnet (needs --run: its config.json and latest checkpoint, or --step), ggcnn and
ggcnn-close (need --run with a GG-CNN from train.py --stage ggcnn), random, highest,
heuristic (see vags_jax/evaluate.py).  Groups, rounds, the attempt budget and the robot-time
model of picks per hour come from the config's benchmark section (--set benchmark.rounds=20).  The configuration is the run's config.json
(or the --config preset) with --set overrides applied; the scene must hold the largest group
(scene.max_objects).  Prints a Markdown table and writes the full report as JSON to --out, or
to RUN/eval_<policy>[_step<N>].json.

Every input (flags, --set values, the run directory and its checkpoint) is checked before
anything is compiled: a bad one ends with one line on stderr and exit code 2.
"""
from __future__ import annotations

import argparse
import os
import sys

from vags_jax import cli

PROG = "eval.py"
MAX_GROUP = 1000  # object counts above this are refused while parsing --groups


def parse_args(argv=None):
    p = cli.ArgumentParser(prog=PROG, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--run", default=None, help="run directory written by train.py (config.json + checkpoints/)")
    p.add_argument("--policy", default=None,
                   help="gdnet | ggcnn | ggcnn-close | random | highest | heuristic (default: gdnet with "
                        "--run, else heuristic)")
    p.add_argument("--config", default=None, help="preset when there is no --run: tiny | gpu | paper | default (default: tiny)")
    p.add_argument("--set", nargs="*", default=[], metavar="SECTION.FIELD=VALUE",
                   help="evaluation config overrides, e.g. scene.max_objects=10 benchmark.max_attempts_extra=5")
    p.add_argument("--groups", default=None,
                   help="object counts: 1,2,3 or 1-10 or 1-3,5 (default: benchmark.groups, else 1..scene.max_objects)")
    p.add_argument("--rounds", type=cli.int_in(1, 1 << 20), default=None,
                   help="rounds per group = parallel worlds (default: benchmark.rounds, 50)")
    p.add_argument("--seed", type=cli.int_in(0, 2**32 - 1), default=None,
                   help="PRNG seed (default: the config's seed)")
    p.add_argument("--step", type=cli.int_in(0), default=None, help="checkpoint step for gdnet (default: latest)")
    p.add_argument("--out", default=None, help="JSON report path (default: RUN/eval_<policy>.json)")
    p.add_argument("--speed", type=cli.positive_float(100.0), default=None,
                   help="motion-time model: gripper speed m/s (default benchmark.speed, 0.5)")
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
                if b < a or b > MAX_GROUP:
                    raise ValueError
                out.extend(range(a, b + 1))
            else:
                out.append(int(part))
    except ValueError:
        raise ValueError(f"--groups {text!r}: expected object counts like 1,2,3 or 1-10") from None
    return sorted(set(out))


def check_rounds_fit(cfg, rounds: int) -> None:
    """--rounds worlds run at once: their Q maps must fit (as stage1.n_worlds, config.py)."""
    from vags_jax import config as C

    px = cfg.workspace.heightmap_px
    need = 2 * rounds * cfg.net.n_rotations * px * px
    if need > C.MAX_DEVICE_BYTES:
        raise ValueError(f"--rounds {rounds:,} worlds need Q maps of {cfg.net.n_rotations} x {px} x {px} "
                         f"each, {need / 2**30:,.0f} GiB at 2 bytes per value, more than "
                         f"{C.MAX_DEVICE_BYTES // 2**30} GiB; lower --rounds")


def main(argv=None) -> int:
    args = parse_args(argv)  # bad flags: one line, exit code 2
    from vags_jax import config as C

    policy = args.policy or ("gdnet" if args.run else "heuristic")
    ggcnn_params = None
    try:
        # Checks with light imports first, so a bad input is refused in about a second ...
        if policy in ("gdnet", "ggcnn", "ggcnn-close") and not args.run:
            raise ValueError(f"policy {policy} needs --run RUN_DIR (a run written by train.py)")
        if args.run and args.config:
            raise ValueError("--run uses the run's own config.json; drop --config (use --set to override)")
        if args.run is not None and not args.run:
            raise ValueError("--run must not be empty")
        if args.run and os.path.exists(args.run) and not os.path.isdir(args.run):
            raise ValueError(f"--run {args.run!r} is a file; give the run directory train.py wrote")
        if args.run and not os.path.isdir(args.run):
            raise ValueError(f"run directory {args.run!r} does not exist")
        if args.step is not None and policy != "gdnet":
            raise ValueError(f"--step selects a gdnet checkpoint; policy {policy!r} uses none: drop --step")
        if args.out is not None:
            cli.check_writable_file(args.out, "--out")
        groups = None if args.groups is None else parse_groups(args.groups)
        overrides = C.parse_overrides(args.set)
        if args.speed is not None:
            if "benchmark.speed" in overrides:
                raise ValueError("give the speed once: --speed or --set benchmark.speed=...")
            overrides["benchmark.speed"] = args.speed
        ggcnn_cfg = None
        if args.run:
            from vags_jax import checkpoint

            if policy in ("ggcnn", "ggcnn-close"):  # no GG-CNN in the run, damaged files
                from vags_jax.ggcnn_stage import ggcnn_dir, load_ggcnn

                ggcnn_params, _ = load_ggcnn(args.run)
                ggcnn_cfg = checkpoint.load_config(ggcnn_dir(args.run))
            # A run that trained only GG-CNN has its config in RUN/ggcnn/.
            gg_only = (not os.path.exists(os.path.join(args.run, "config.json"))
                       and os.path.isfile(os.path.join(args.run, "ggcnn", "config.json")))
            if gg_only and policy == "gdnet":
                raise ValueError(f"run {args.run} holds only a GG-CNN ({args.run}/ggcnn): evaluate it with "
                                 f"--policy ggcnn or ggcnn-close, or train GDNet into it with "
                                 f"python train.py --out {args.run}")
            if gg_only:
                run_cfg = ggcnn_cfg if ggcnn_cfg is not None else checkpoint.load_config(os.path.join(args.run, "ggcnn"))
            else:
                run_cfg = checkpoint.load_config(args.run)  # missing / damaged config.json
            if policy == "gdnet":  # missing step, damaged files
                checkpoint.read(args.run, args.step, parts=["learner"])
        else:
            run_cfg = C.preset(args.config or "tiny")
        scene_over = dict(C.LEGACY_SCENES) if args.scenes == "legacy" else {}
        if args.objects:
            scene_over.update({"scene.shapes": C.object_pool(args.objects, run_cfg.scene.pool_size),
                               "scene.copies_per_shape": 1})
        cfg = C.replace(run_cfg, **scene_over, **overrides)
        from vags_jax import scene

        scene.build_spec(cfg)  # the scene's own checks (shape names), in milliseconds
        if policy == "gdnet" and (cfg.net != run_cfg.net or cfg.workspace != run_cfg.workspace):
            raise ValueError("--set must not change net.* or workspace.*: the trained GDNet needs the "
                             "network and heightmaps it was trained with")
        if ggcnn_cfg is not None and (
                (cfg.ggcnn.input_size, cfg.ggcnn.crop_size) != (ggcnn_cfg.ggcnn.input_size, ggcnn_cfg.ggcnn.crop_size)
                or (cfg.camera.width, cfg.camera.height, cfg.camera.fx, cfg.camera.fy)
                != (ggcnn_cfg.camera.width, ggcnn_cfg.camera.height, ggcnn_cfg.camera.fx, ggcnn_cfg.camera.fy)):
            raise ValueError("the evaluation config has another ggcnn.input_size / crop_size or camera image size "
                             "or focal length than the GG-CNN was trained with (RUN/ggcnn/config.json): it needs "
                             "the image scale it was trained on")
        rounds = cfg.benchmark.rounds if args.rounds is None else args.rounds
        groups = C.benchmark_groups(cfg) if groups is None else groups
        check_rounds_fit(cfg, rounds)
        # ... then the rest, which needs the simulator's modules (still nothing compiled).
        from vags_jax import evaluate as E

        if policy not in E.POLICIES:
            raise ValueError(f"unknown policy {policy!r}; choose one of {', '.join(E.POLICIES)}")
        variables, step = None, None
        if policy == "gdnet":  # the learner, checked against the run's network config
            _, variables, step = E.load_gdnet(args.run, args.step)
        groups = E.check_groups(groups, cfg, rounds)
        time_model = E.MotionTimeModel.from_config(cfg)
        out = args.out
        if out is None and args.run:
            tag = "".join(f"_{t}" for t in (args.objects, args.scenes) if t)
            out = os.path.join(args.run, f"eval_{policy}{tag}" + (f"_step{step}" if step is not None else "") + ".json")
            cli.check_writable_file(out, "--run")
    except ValueError as e:  # includes CheckpointError and config validation
        return cli.fail(PROG, e)

    import jax

    print(f"evaluating {policy}" + (f" ({args.run}, checkpoint {step})" if step is not None else "")
          + f": groups {groups}, {rounds} rounds each, impl={cfg.sim.impl}, devices={jax.devices()}",
          file=sys.stderr)
    ev = E.Evaluator(cfg)
    pol = E.make_policy(policy, cfg, variables, ggcnn_params)
    report = E.evaluate(cfg, pol, groups, rounds, args.seed, time_model, ev,
                        log=lambda s: print(s, file=sys.stderr, flush=True))
    print(E.format_table(report))
    if out:
        E.save_report(report, out, cfg, {"run": args.run, "checkpoint_step": step})
        print(f"wrote {out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
