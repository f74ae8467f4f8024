#!/usr/bin/env python3
"""Benchmark a grasping policy (docs/benchmark.md): groups of k objects, R rounds each.

    python eval.py --run runs/tiny --groups 1,2,3 --rounds 4          # trained GDNet, greedy
    python eval.py --run runs/tiny --policy heuristic --groups 1-3    # scripted baseline, same config
    python eval.py --config tiny --policy random --groups 1,2 --rounds 8 --out runs/random.json
    python eval.py --run runs/gpu --set scene.max_objects=10 scene.copies_per_shape=2   # 1..10
    python eval.py --run runs/gpu --objects unseen      # held-out shapes the GDNet never saw
    python eval.py --run runs/gpu --policy ggcnn-close  # GG-CNN of train.py --stage ggcnn, close view
    python eval.py --run runs/gpu                       # VAGS (the run's networks and threshold)
    python eval.py --run runs/gpu --no-viewpoint        # VAGS without VANet: GDNet alone
    python eval.py --run runs/gpu --threshold-sweep 1.70:1.80:0.01 --quantile-sweep 0:1:0.1 --plot runs/gpu/fig.png
    python eval.py --run runs/gpu --record runs/gpu/pictures --groups 3,10

Policies: vags (the default for a run with stage 2 or 3 networks: GDNet, VANet, GG-CNN and
the run's decision threshold, or --threshold), gdnet (the default for a stage-1 run; --step
picks a checkpoint), ggcnn and ggcnn-close (need --run with a GG-CNN from train.py --stage
ggcnn), random, highest, heuristic (see vags_jax/evaluate.py).  --no-viewpoint runs VAGS with
its GDNet alone (threshold -inf: the paper's "w/o VANet" ablation).  --threshold-sweep A:B:STEP
evaluates VAGS at each absolute threshold (paper Fig. 6), --quantile-sweep A:B:STEP at the
quantiles of the largest GDNet Q that VAGS saw at its decisions in the main run (our Q scale
need not match the paper's); the sweep goes to RUN/eval_vags_sweep.json and .csv.  Groups, rounds, the attempt budget and the robot-time
model of picks per hour come from the config's benchmark section (--set benchmark.rounds=20).  The configuration is the run's config.json
(or the --config preset) with --set overrides applied; the scene must hold the largest group
(scene.max_objects).  Prints a Markdown table and writes the full report as JSON to --out, or
to RUN/eval_<policy>[_step<N>].json, with a CSV beside it (one row per group and overall).
--plot PATH draws success and clearing against the number of objects (paper Fig. 7) for this
report and the reports given with --compare (needs matplotlib: pip install 'vags_jax[plot]');
with a sweep, the sweep's plot goes beside it (PATH stem + _sweep.png).  --record DIR writes
pictures of the first --record-rounds rounds of each group (vags only).

Every input (flags, --set values, the run directory and its checkpoint) is checked before
anything is compiled: a bad one ends with one line on stderr and exit code 2.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import sys

from vags_jax import cli

PROG = "eval.py"
MAX_GROUP = 1000  # object counts above this are refused while parsing --groups


def parse_args(argv=None):
    p = cli.ArgumentParser(prog=PROG, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--run", default=None, help="run directory written by train.py (config.json + checkpoints/)")
    p.add_argument("--policy", default=None,
                   help="vags | gdnet | ggcnn | ggcnn-close | random | highest | heuristic (default: vags for "
                        "a run with stage 2 or 3, gdnet for a stage-1 run, else heuristic)")
    p.add_argument("--threshold", type=float, default=None,
                   help="vags: the decision threshold (default: the run's, stored by stage 2)")
    p.add_argument("--no-viewpoint", action="store_true",
                   help="vags without VANet: always grasp directly with its GDNet (threshold -inf)")
    p.add_argument("--threshold-sweep", default=None, metavar="A:B:STEP",
                   help="vags: also evaluate at each threshold A, A+STEP, ..., B (e.g. 1.70:1.80:0.01)")
    p.add_argument("--quantile-sweep", default=None, metavar="A:B:STEP",
                   help="vags: also evaluate at these quantiles (0..1) of the largest GDNet Q seen at the "
                        "main run's decisions (e.g. 0:1:0.1)")
    p.add_argument("--plot", default=None, metavar="PATH.png",
                   help="success and clearing vs objects (paper Fig. 7); needs matplotlib")
    p.add_argument("--compare", nargs="*", default=[], metavar="REPORT.json",
                   help="--plot: other eval.py reports drawn beside this one")
    p.add_argument("--record", default=None, metavar="DIR",
                   help="vags: pictures of the first --record-rounds rounds of each group")
    p.add_argument("--record-rounds", type=cli.int_in(1, 1000), default=1,
                   help="rounds per group that --record draws (default 1)")
    p.add_argument("--config", default=None, help="preset when there is no --run: tiny | gpu | gpu-edge | paper | default (default: tiny)")
    p.add_argument("--set", nargs="*", default=[], metavar="SECTION.FIELD=VALUE",
                   help="evaluation config overrides, e.g. scene.max_objects=10 benchmark.max_attempts_extra=5")
    p.add_argument("--groups", default=None,
                   help="object counts: 1,2,3 or 1-10 or 1-3,5 (default: benchmark.groups, else 1..scene.max_objects)")
    p.add_argument("--rounds", type=cli.int_in(1, 1 << 20), default=None,
                   help="rounds per group = parallel worlds (default: benchmark.rounds, 50)")
    p.add_argument("--seed", type=cli.int_in(0, 2**32 - 1), default=None,
                   help="PRNG seed (default: the config's seed)")
    p.add_argument("--seeds", default=None, metavar="S1,S2,...",
                   help="several seeds, each a full table, compiled once: --out must hold {seed} (default: "
                        "RUN/eval_<policy>_seed<S>.json); prints each seed's overall figures and their mean")
    p.add_argument("--step", type=cli.int_in(0), default=None, help="checkpoint step for gdnet (default: latest)")
    p.add_argument("--out", default=None, help="JSON report path (default: RUN/eval_<policy>.json)")
    p.add_argument("--speed", type=cli.positive_float(100.0), default=None,
                   help="motion-time model: gripper speed m/s (default benchmark.speed, 0.5)")
    p.add_argument("--objects", default=None, choices=("train", "unseen", "legacy"),
                   help="object set of the scenes (default: the config's pool; 'unseen': the held-out "
                        "shapes, never trained on)")
    p.add_argument("--scenes", default=None, choices=("paper", "edge", "legacy"),
                   help="'edge': the variant with piles up to the workspace edges and a global view that "
                        "just holds the workspace (docs/benchmark.md); 'legacy': the first benchmark's "
                        "scenes (fixed blocks scattered apart, noiseless camera from the old pose), for "
                        "comparisons with earlier results")
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


def parse_seeds(text: str) -> list[int]:
    """"11,12,13" -> [11, 12, 13] (distinct seeds in 0 .. 2**32 - 1, in the order given)."""
    try:
        seeds = [int(t) for t in text.split(",")]
    except ValueError:
        seeds = []
    if not seeds or any(not 0 <= x < 2**32 for x in seeds) or len(set(seeds)) != len(seeds):
        raise ValueError(f"--seeds {text!r}: expected distinct seeds in 0..{2**32 - 1} like 11,12,13")
    return seeds


def seed_path(out: str, seed: int) -> str:
    """--out of one seed of --seeds: ``{seed}`` in ``out`` replaced by the seed."""
    return out.replace("{seed}", str(seed))


def check_rounds_fit(cfg, rounds: int, n_groups: int = 1) -> None:
    """rounds x groups worlds run at once: their Q maps must fit (as stage1.n_worlds, config.py)."""
    from vags_jax import config as C

    px = cfg.workspace.heightmap_px
    need = 2 * rounds * n_groups * cfg.net.n_rotations * px * px
    if need > C.MAX_DEVICE_BYTES:
        raise ValueError(f"--rounds {rounds:,} x {n_groups} groups = {rounds * n_groups:,} worlds (every group "
                         f"plays in one batch) need Q maps of {cfg.net.n_rotations} x {px} x {px} "
                         f"each, {need / 2**30:,.0f} GiB at 2 bytes per value, more than "
                         f"{C.MAX_DEVICE_BYTES // 2**30} GiB; lower --rounds")


def parse_sweep(text: str, flag: str, lo=None, hi=None) -> list[float]:
    """"A:B:STEP" -> [A, A + STEP, ..., B] (rounded to 10 decimals; at most 1000 values)."""
    import math

    parts = text.split(":")
    try:
        if len(parts) != 3:
            raise ValueError
        a, b, step = (float(x) for x in parts)
        if not all(math.isfinite(v) for v in (a, b, step)):
            raise ValueError
    except ValueError:
        raise ValueError(f"{flag} {text!r}: expected START:STOP:STEP, e.g. 1.70:1.80:0.01") from None
    if step <= 0 or b < a:
        raise ValueError(f"{flag} {text!r}: STEP must be > 0 and STOP >= START")
    n = int(round((b - a) / step)) + 1
    if n > 1000:
        raise ValueError(f"{flag} {text!r} gives {n} values; at most 1000")
    values = [round(min(a + i * step, b), 10) for i in range(n)]
    if (lo is not None and values[0] < lo) or (hi is not None and values[-1] > hi):
        raise ValueError(f"{flag} {text!r}: values must lie in [{lo}, {hi}]")
    return values


def run_has_vags(run: str) -> bool:
    from vags_jax import checkpoint, pipeline

    return any(os.path.isdir(pipeline.networks_dir(run, n)) and checkpoint.checkpoint_steps(pipeline.networks_dir(run, n))
               for n in ("stage2", "stage3"))


def main(argv=None) -> int:
    args = parse_args(argv)  # bad flags: one line, exit code 2
    from vags_jax import config as C

    ggcnn_params = networks = None
    try:
        # Checks with light imports first, so a bad input is refused in about a second ...
        if args.run is not None and args.run and os.path.isdir(args.run):
            policy = args.policy or ("vags" if run_has_vags(args.run) else "gdnet")
        else:
            policy = args.policy or ("gdnet" if args.run else "heuristic")
        if policy in ("vags", "gdnet", "ggcnn", "ggcnn-close") and not args.run:
            raise ValueError(f"policy {policy} needs --run RUN_DIR (a run written by train.py)")
        vags_only = [f for f, v in (("--threshold", args.threshold is not None), ("--no-viewpoint", args.no_viewpoint),
                                    ("--threshold-sweep", args.threshold_sweep), ("--quantile-sweep", args.quantile_sweep),
                                    ("--record", args.record)) if v]
        if vags_only and policy != "vags":
            raise ValueError(f"{vags_only[0]} is for --policy vags, not {policy}")
        seeds = [args.seed] if args.seeds is None else parse_seeds(args.seeds)
        if args.seeds is not None:
            given = [f for f, v in (("--seed", args.seed is not None), ("--threshold-sweep", args.threshold_sweep),
                                    ("--quantile-sweep", args.quantile_sweep), ("--record", args.record),
                                    ("--plot", args.plot)) if v]
            if given:
                raise ValueError(f"--seeds plays whole tables only; drop {given[0]} (or give one seed with --seed)")
            if args.out is not None and "{seed}" not in args.out:
                raise ValueError(f"--out {args.out!r} must contain {{seed}} with --seeds, e.g. res/seed{{seed}}/eval.json")
        if args.no_viewpoint and (args.threshold is not None or args.threshold_sweep or args.quantile_sweep):
            raise ValueError("--no-viewpoint fixes the threshold at -inf: drop --threshold and the sweeps")
        if args.threshold is not None and not math.isfinite(args.threshold):
            raise ValueError(f"--threshold must be a finite number, got {args.threshold}")
        sweep_abs = parse_sweep(args.threshold_sweep, "--threshold-sweep") if args.threshold_sweep else []
        sweep_q = parse_sweep(args.quantile_sweep, "--quantile-sweep", 0.0, 1.0) if args.quantile_sweep else []
        if args.compare and not args.plot:
            raise ValueError("--compare adds reports to --plot: give --plot PATH.png")
        compare = {}
        for path in args.compare:
            try:
                with open(path, encoding="utf-8") as f:
                    rep_ = json.load(f)
                label = rep_["policy"]
                rep_["groups_metrics"], rep_["overall"]  # noqa: B018 (the keys the plot reads)
            except (OSError, ValueError, KeyError, TypeError) as e:
                raise ValueError(f"--compare {path}: not a report written by eval.py ({cli.first_line(e)})") from None
            compare[label if label not in compare else f"{label} ({path})"] = rep_
        if args.plot:
            cli.check_writable_file(args.plot, "--plot")
            from vags_jax import report_files

            report_files.check_plot_available()
        if args.record:
            if os.path.exists(args.record) and not os.path.isdir(args.record):
                raise ValueError(f"--record {args.record!r} is a file; give a directory for the pictures")
            cli._check_parent_writable(os.path.join(args.record, "x"), "--record")
        if args.run and args.config:
            raise ValueError("--run uses the run's own config.json; drop --config (use --set to override)")
        if args.run is not None and not args.run:
            raise ValueError("--run must not be empty")
        if args.run and os.path.exists(args.run) and not os.path.isdir(args.run):
            raise ValueError(f"--run {args.run!r} is a file; give the run directory train.py wrote")
        if args.run and not os.path.isdir(args.run):
            raise ValueError(f"run directory {args.run!r} does not exist")
        if args.step is not None and policy not in ("gdnet", "vags"):
            raise ValueError(f"--step selects a gdnet or vags checkpoint; policy {policy!r} uses none: drop --step")
        if args.out is not None:
            for seed in seeds:
                cli.check_writable_file(args.out if args.seeds is None else seed_path(args.out, seed), "--out")
        groups = None if args.groups is None else parse_groups(args.groups)
        overrides = C.parse_overrides(args.set)
        if args.speed is not None:
            if "benchmark.speed" in overrides:
                raise ValueError("give the speed once: --speed or --set benchmark.speed=...")
            overrides["benchmark.speed"] = args.speed
        ggcnn_cfg = None
        if args.run:
            from vags_jax import checkpoint

            if policy == "vags":  # no stage 2/3 networks, no GG-CNN, damaged files
                from vags_jax import pipeline

                networks = pipeline.load_vags(args.run, step=args.step)
                if networks.ggcnn is not None:
                    ggcnn_cfg = checkpoint.load_config(os.path.join(args.run, "ggcnn"))
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
        scene_over = {"legacy": C.LEGACY_SCENES, "edge": C.EDGE_SCENES}.get(args.scenes, {})
        scene_over = dict(scene_over)
        if args.objects:
            scene_over.update({"scene.shapes": C.object_pool(args.objects, run_cfg.scene.pool_size),
                               "scene.copies_per_shape": 1})
        cfg = C.replace(run_cfg, **scene_over, **overrides)
        from vags_jax import scene

        scene.build_spec(cfg)  # the scene's own checks (shape names), in milliseconds
        if policy in ("gdnet", "vags") and (cfg.net != run_cfg.net or cfg.workspace != run_cfg.workspace):
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
        check_rounds_fit(cfg, rounds, len(groups))
        if args.record and args.record_rounds > rounds:
            raise ValueError(f"--record-rounds {args.record_rounds} exceeds the {rounds} rounds per group")
        # ... then the rest, which needs the simulator's modules (still nothing compiled).
        from vags_jax import evaluate as E

        if policy not in E.POLICIES:
            raise ValueError(f"unknown policy {policy!r}; choose one of {', '.join(E.POLICIES)}")
        variables, step = None, None
        if policy == "gdnet":  # the learner, checked against the run's network config
            _, variables, step = E.load_gdnet(args.run, args.step)
        if policy == "vags":  # the config's gate / close-view planner against the run's networks
            E.vags_params(networks, cfg)
        groups = E.check_groups(groups, cfg, rounds)
        time_model = E.MotionTimeModel.from_config(cfg)
        name = "vags-no-viewpoint" if args.no_viewpoint else policy
        out = args.out
        if out is None and args.run:
            tag = "".join(f"_{t}" for t in (args.objects, args.scenes) if t)
            tag += "" if args.seeds is None else "_seed{seed}"
            out = os.path.join(args.run, f"eval_{name}{tag}" + (f"_step{step}" if step is not None else "") + ".json")
            for seed in seeds:
                cli.check_writable_file(seed_path(out, seed), "--run")
        sweep_out = None
        if sweep_abs or sweep_q:
            sweep_out = os.path.splitext(out)[0] + "_sweep.json" if out else None
    except ValueError as e:  # includes CheckpointError and config validation
        return cli.fail(PROG, e)

    import jax

    import numpy as np

    from vags_jax import report_files

    log = lambda s: print(s, file=sys.stderr, flush=True)  # noqa: E731
    threshold = -math.inf if args.no_viewpoint else args.threshold
    source = f" ({args.run}, checkpoint {step})" if step is not None else (
        f" ({args.run}, {networks.source})" if networks is not None else "")
    log(f"evaluating {name}{source}: groups {groups}, {rounds} rounds each, impl={cfg.sim.impl}, "
        f"devices={jax.devices()}")
    ev = E.Evaluator(cfg)
    pol = E.make_policy(policy, cfg, variables, ggcnn_params, networks, threshold)
    if policy == "vags":
        pol = dataclasses.replace(pol, name=name)
    extra = {"run": args.run, "checkpoint_step": step}
    overall = {}
    for seed in seeds:  # one Evaluator: every seed reuses the programs the first one compiled
        if args.seeds is not None:
            print(f"\nseed {seed}")
        report = E.evaluate(cfg, pol, groups, rounds, seed, time_model, ev, log=log)
        if policy == "vags":
            report["threshold"] = float(np.asarray(pol.params["threshold"]))
            extra["networks"] = networks.source
            log(f"decision threshold {report['threshold']:.4f}")
        print(E.format_table(report))
        overall[report["seed"]] = report["overall"]
        path = out if args.seeds is None or not out else seed_path(out, seed)
        if path:
            E.save_report(report, path, cfg, extra)
            report_files.write_csv(report, os.path.splitext(path)[0] + ".csv",
                                   {"threshold": report["threshold"]} if "threshold" in report else None)
            log(f"wrote {path} and {os.path.splitext(path)[0]}.csv")
    if args.seeds is not None:
        print(format_seeds(name, overall))
    if sweep_abs or sweep_q:
        rows = run_sweep(cfg, ev, pol, report, sweep_abs, sweep_q, groups, rounds, args.seed, time_model, log)
        print(format_sweep(rows))
        if sweep_out:
            E.save_report({"policy": name, "rows": rows}, sweep_out, cfg, extra)
            report_files.write_sweep_csv(rows, os.path.splitext(sweep_out)[0] + ".csv")
            log(f"wrote {sweep_out} and {os.path.splitext(sweep_out)[0]}.csv")
        if args.plot:
            path = os.path.splitext(args.plot)[0] + "_sweep.png"
            report_files.plot_sweep(rows, path, title=f"{name}: grasp success vs threshold")
            log(f"wrote {path}")
    if args.plot:
        report_files.plot_by_objects({name: report, **compare}, args.plot)
        log(f"wrote {args.plot}")
    if args.record:
        from vags_jax.record_rounds import record_rounds

        record_rounds(cfg, ev, pol.params, report["seed"], groups, args.record_rounds, rounds, args.record, log)
    return 0


def format_seeds(name: str, overall: dict) -> str:
    """A Markdown table of each seed's overall figures (``{seed: report["overall"]}``) and their mean."""
    keys = [("grasp_success_rate", "grasp success %", 100), ("clearing_rate", "clearing %", 100),
            ("motion_number", "motion number", 1), ("viewpoint_rate", "viewpoint %", 100)]
    fmt = lambda x, m: "-" if x is None else f"{x * m:.{1 if m == 100 else 2}f}"  # noqa: E731
    lines = [f"| {name}: seed | " + " | ".join(k[1] for k in keys) + " |", "|---" * (len(keys) + 1) + "|"]
    for seed, o in overall.items():
        lines.append(f"| {seed} | " + " | ".join(fmt(o.get(k), m) for k, _, m in keys) + " |")
    mean = []
    for k, _, m in keys:
        vals = [o.get(k) for o in overall.values()]
        mean.append("-" if None in vals else f"**{fmt(sum(vals) / len(vals), m)}**")
    lines.append("| **mean** | " + " | ".join(mean) + " |")
    return "\n".join(lines)


def run_sweep(cfg, ev, pol, report, sweep_abs, sweep_q, groups, rounds, seed, time_model, log) -> list[dict]:
    """The benchmark at each threshold (absolute values, then quantiles of the largest GDNet Q
    seen at the main run's decisions) -> rows for report_files.write_sweep_csv."""
    import dataclasses as dc

    import jax.numpy as jnp
    import numpy as np

    from vags_jax import evaluate as E

    scores = np.concatenate([np.asarray(o["scores"], np.float64).ravel() for o in report["outcomes"].values()])
    scores = scores[np.isfinite(scores)]
    points = [("absolute", None, t) for t in sweep_abs]
    if sweep_q:
        if scores.size == 0:
            raise SystemExit(f"{PROG}: error: the main run recorded no decision values to take quantiles of")
        points += [("quantile", q, float(np.quantile(scores, q))) for q in sweep_q]
    rows = []
    for kind, q, thr in points:
        p = dc.replace(pol, params={**pol.params, "threshold": jnp.asarray(thr, jnp.float32)})
        r = E.evaluate(cfg, p, groups, rounds, seed, time_model, ev)
        o = r["overall"]
        log(f"sweep {kind} {'' if q is None else f'q={q:g} '}threshold {thr:.4f}: success "
            f"{E._pct(o['grasp_success_rate'])} %, clearing {E._pct(o['clearing_rate'])} %, viewpoint "
            f"{E._pct(o['viewpoint_rate'])} %")
        rows.append({"kind": kind, "quantile": q, "threshold": thr, "overall": o, "groups_metrics": r["groups_metrics"]})
    return rows


def format_sweep(rows: list[dict]) -> str:
    """Markdown table of a threshold sweep."""
    from vags_jax import evaluate as E

    out = ["| sweep | quantile | threshold | grasp success % | clearing % | motion number | viewpoint % | picks/hour |",
           "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        o = r["overall"]
        out.append(f"| {r['kind']} | {'-' if r['quantile'] is None else format(r['quantile'], 'g')} | "
                   f"{r['threshold']:.4f} | {E._pct(o['grasp_success_rate'])} | {E._pct(o['clearing_rate'])} | "
                   f"{E._num(o['motion_number'])} | {E._pct(o['viewpoint_rate'])} | {E._num(o['picks_per_hour'], '{:.0f}')} |")
    return "\n".join(out)


if __name__ == "__main__":
    sys.exit(main())
