"""What ``eval.py`` checks before anything is compiled: flags, ``--set`` values, the run
directory and its checkpoint, the groups and rounds against the config.

``prepare_eval(args)`` takes the parsed command line and returns the plan ``eval.py`` runs
(``SimpleNamespace``: policy, cfg, groups, rounds, networks / variables / ggcnn_params, out
paths, sweeps), or raises ``ValueError`` (``CheckpointError``) with one line saying what to fix.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
from types import SimpleNamespace

from vags_jax import cli
from vags_jax import config as C
from vags_jax.benchmark import metrics as M
from vags_jax.benchmark import protocol as E
from vags_jax.benchmark import reports
from vags_jax.perception import render
from vags_jax.policies import catalog as P
from vags_jax.sim import scene
from vags_jax.policies import rate_gate
from vags_jax.stages import checkpoint, rundir
from vags_jax.stages.ggcnn import ggcnn_dir, load_ggcnn
from vags_jax.stages.vpg import load_vpg

MAX_GROUP = 1000  # object counts above this are refused while parsing --groups


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
    px = cfg.workspace.heightmap_px
    need = 2 * rounds * n_groups * cfg.net.n_rotations * px * px
    if need > C.MAX_DEVICE_BYTES:
        raise ValueError(f"--rounds {rounds:,} x {n_groups} groups = {rounds * n_groups:,} worlds (every group "
                         f"plays in one batch) need Q maps of {cfg.net.n_rotations} x {px} x {px} "
                         f"each, {need / 2**30:,.0f} GiB at 2 bytes per value, more than "
                         f"{C.MAX_DEVICE_BYTES // 2**30} GiB; lower --rounds")


def parse_sweep(text: str, flag: str, lo=None, hi=None) -> list[float]:
    """"A:B:STEP" -> [A, A + STEP, ..., B] (rounded to 10 decimals; at most 1000 values)."""
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
    span = (b - a) / step  # inf when the range overflows a float
    if not span <= 999:
        count = f"{int(round(span)) + 1:,}" if math.isfinite(span) else "more than 10^308"
        raise ValueError(f"{flag} {text!r} gives {count} values; at most 1000 (a larger STEP or a narrower range)")
    n = int(round(span)) + 1
    values = [round(min(a + i * step, b), 10) for i in range(n)]
    if (lo is not None and values[0] < lo) or (hi is not None and values[-1] > hi):
        raise ValueError(f"{flag} {text!r}: values must lie in [{lo}, {hi}]")
    return values


def run_has_vags(run: str) -> bool:
    return any(os.path.isdir(rundir.networks_dir(run, n)) and checkpoint.checkpoint_steps(rundir.networks_dir(run, n))
               for n in ("stage2", "stage3"))


def _check_flags(args):
    """The flags that need no run or config -> (policy, seeds, absolute sweep, quantile sweep,
    reports to compare)."""
    if args.run is not None and args.run and os.path.isdir(args.run):
        policy = args.policy or ("vags" if run_has_vags(args.run) else "gdnet")
    else:
        policy = args.policy or ("gdnet" if args.run else "heuristic")
    if policy in ("vags", "gdnet", "nbv", "vpg") + P.GGCNN_POLICIES and not args.run:
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
    compare = {}  # --compare is its own mode (prepare_compare); here it is always empty
    if args.plot:
        if os.path.splitext(args.plot)[1].lower() != ".png":
            raise ValueError(f"--plot {args.plot!r}: the plot is a PNG image; give a path ending in .png")
        cli.check_writable_file(args.plot, "--plot")
        reports.check_plot_available()
    if args.record:
        if os.path.exists(args.record) and not os.path.isdir(args.record):
            raise ValueError(f"--record {args.record!r} is a file; give a directory for the pictures")
        try:
            cli.check_parent_writable(os.path.join(args.record, "x"), "--record")
        except ValueError as e:  # name the directory asked for, not the probe file inside it
            raise ValueError(str(e).replace(repr(os.path.join(args.record, "x")), repr(args.record), 1)) from None
    if args.run and args.config:
        raise ValueError("--run uses the run's own config.json; drop --config (use --set to override)")
    if args.run is not None and not args.run:
        raise ValueError("--run must not be empty")
    if args.run and os.path.exists(args.run) and not os.path.isdir(args.run):
        raise ValueError(f"--run {args.run!r} is a file; give the run directory train.py wrote")
    if args.run and not os.path.isdir(args.run):
        raise ValueError(f"run directory {args.run!r} does not exist")
    if args.networks is not None and policy != "vags":
        raise ValueError(f"--networks selects a stage's VAGS networks; policy {policy!r} uses none: drop --networks")
    if args.step is not None and policy not in ("gdnet", "vags", "vpg"):
        raise ValueError(f"--step selects a gdnet, vags or vpg checkpoint; policy {policy!r} uses none: drop --step")
    if args.out is not None:
        for seed in seeds:
            cli.check_writable_file(args.out if args.seeds is None else seed_path(args.out, seed), "--out")
    return policy, seeds, sweep_abs, sweep_q, compare


def load_report(path: str) -> dict:
    """A report ``eval.py`` wrote (JSON) -> its dict; ValueError naming the file otherwise."""
    try:
        with open(path, encoding="utf-8") as f:
            rep = json.load(f)
        rep["policy"], rep["groups_metrics"], rep["overall"]  # noqa: B018 (the keys a table reads)
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise ValueError(f"--compare {path}: not a report written by eval.py ({cli.first_line(e)})") from None
    return rep


# The config sections that decide the scenes and the robot-time model: every method of one
# comparison must have the same.
SCENE_SECTIONS = ("workspace", "scene", "sim", "grasp", "camera", "benchmark")


def _split_item(item: str, default_run):
    """A --compare item that is not a report -> (run directory or None, policy or None)."""
    if os.path.isdir(item):
        return item, None
    if item in P.POLICIES:
        return default_run, item
    if ":" in item:
        run, policy = item.rsplit(":", 1)
        if not os.path.isdir(run):
            raise ValueError(f"--compare {item}: run directory {run!r} does not exist")
        return run, policy
    raise ValueError(f"--compare {item!r}: not a policy ({', '.join(P.POLICIES)}), a run directory, RUN:policy "
                     f"or a report .json written by eval.py")


def prepare_compare(args) -> SimpleNamespace:
    """``eval.py --compare ITEM ...`` (and ``--policy``, the first method when given): every
    method checked as a single ``eval.py`` call would be (``prepare_eval``), and all of them
    against each other (one scene config, one seed) before anything is compiled -> plan:
    methods [(label, plan or None, saved report or None)], cfg, groups, rounds, seed,
    time_model, out."""
    given = [f for f, v in (("--seeds", args.seeds), ("--threshold-sweep", args.threshold_sweep),
                            ("--quantile-sweep", args.quantile_sweep), ("--record", args.record)) if v]
    if given:
        raise ValueError(f"--compare plays one table of several methods; drop {given[0]}")
    if args.plot:
        cli.check_writable_file(args.plot, "--plot")
        reports.check_plot_available()
    if args.out is not None:
        cli.check_writable_file(args.out, "--out")
    items = ([args.policy] if args.policy else []) + list(args.compare)
    methods, labels = [], set()
    for item in items:
        if item.endswith(".json"):
            rep, plan = load_report(item), None
            name = rep["policy"]
        else:
            run, policy = _split_item(item, args.run)
            sub = argparse.Namespace(**{**vars(args), "run": run, "policy": policy, "compare": [], "plot": None,
                                        "out": None, "config": None if run else args.config})
            try:
                plan = prepare_eval(sub)
            except ValueError as e:
                raise ValueError(f"--compare {item}: {e}") from None
            plan.run, rep, name = run, None, plan.name
        label = name if name not in labels else f"{name} ({item})"
        labels.add(label)
        methods.append((label, plan, rep))
    played = [p for _, p, _ in methods if p is not None]
    cfg = played[0].cfg if played else None
    for label, p, _ in methods:
        if p is None:
            continue
        bad = [s for s in SCENE_SECTIONS if getattr(p.cfg, s) != getattr(cfg, s)]
        if bad or p.groups != played[0].groups or p.rounds != played[0].rounds:
            what = f"its config's {bad[0]} section" if bad else "its groups or rounds"
            raise ValueError(f"--compare: {label} would play other scenes than {methods[0][0]} ({what} differ); "
                             f"compare runs trained on the same scenes, or evaluate them apart")
    out = args.out
    if out is None and args.run and played:
        tag = "".join(f"_{t}" for t in (args.networks, args.objects, args.scenes) if t)
        out = os.path.join(args.run, f"compare{tag}.json")
        cli.check_writable_file(out, "--run")
    seed = None if not played else (cfg.seed if args.seed is None else args.seed)
    plan = SimpleNamespace(methods=methods, cfg=cfg, seed=seed, out=out,
                           groups=played[0].groups if played else None, rounds=played[0].rounds if played else None,
                           time_model=played[0].time_model if played else None)
    saved = {label: rep for label, _, rep in methods if rep is not None}
    if saved and played:  # a saved report joins only a table of the same scenes
        for label, rep in saved.items():
            for key, want in (("seed", seed), ("groups", list(plan.groups)), ("rounds", plan.rounds)):
                if rep.get(key) != want:
                    raise ValueError(f"--compare: the report of {label} played {key} {rep.get(key)}, this table "
                                     f"{want}: a table needs every method on the same scenes")
    return plan


# --set fields that change what rundir.load_vags returns (the decision's GDNets and gate table).
LOAD_FIELDS = ("vags.stage3_gdnet_pick", "vags.max_motion_number", "vags.cap_split", "vags.gate_min_z")


def _run_config(args, policy, overrides=None):
    """The run's (or preset's) config and what the policy loads from the run -> (run_cfg,
    VAGS networks or None, GG-CNN params or None, GG-CNN's config or None).  The fields of
    ``LOAD_FIELDS`` in ``overrides`` reach the VAGS networks as they load: the GDNet picked
    (``vags.stage3_gdnet_pick``) and what the gate table's moves keep (``vags.gate_min_z``,
    ``vags.max_motion_number``, ``vags.cap_split``)."""
    networks = ggcnn_params = None
    ggcnn_cfg = None
    if args.run:
        if policy in ("vags", "nbv"):  # no stage 2/3 (nbv) networks, no GG-CNN, damaged files
            given = {k: v for k, v in (overrides or {}).items() if k in LOAD_FIELDS}
            load_cfg = C.replace(checkpoint.load_config(args.run), **given) if given else None
            networks = (rundir.load_vags(args.run, load_cfg, step=args.step, stage=args.networks)
                        if policy == "vags"
                        else rundir.load_nbv(args.run))
            if networks.ggcnn is not None:
                ggcnn_cfg = checkpoint.load_config(os.path.join(args.run, "ggcnn"))
        if policy in P.GGCNN_POLICIES:  # no GG-CNN in the run, damaged files
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
        run_cfg = C.preset("tiny" if args.config is None else args.config)
    return run_cfg, networks, ggcnn_params, ggcnn_cfg


def _eval_config(args, policy, run_cfg, ggcnn_cfg, overrides):
    """The evaluation config: the run's with the scene variant, object set and ``--set``
    overrides, checked against what the trained networks need."""
    scene_over = {"legacy": C.LEGACY_SCENES, "edge": C.EDGE_SCENES}.get(args.scenes, {})
    scene_over = dict(scene_over)
    if args.objects:
        scene_over.update({"scene.shapes": C.object_pool(args.objects, run_cfg.scene.pool_size),
                           "scene.copies_per_shape": 1})
    cfg = C.replace(run_cfg, **scene_over, **overrides)
    scene.build_spec(cfg)  # the scene's own checks (shape names), in milliseconds
    # The rotations GDNet is evaluated over are not parameters: any count or span reads the same weights.
    turns = {"n_rotations": run_cfg.net.n_rotations, "half_turn": run_cfg.net.half_turn}
    if policy in ("gdnet", "vags", "nbv", "vpg") and (dataclasses.replace(cfg.net, **turns) != run_cfg.net
                                                     or cfg.workspace != run_cfg.workspace):
        raise ValueError("--set must not change net.* (but net.n_rotations and net.half_turn, with grasp.*'s) "
                         "or workspace.*: the trained GDNet needs the network and heightmaps it was trained with")
    if ggcnn_cfg is not None and (
            (cfg.ggcnn.input_size, cfg.ggcnn.crop_size) != (ggcnn_cfg.ggcnn.input_size, ggcnn_cfg.ggcnn.crop_size)
            or (cfg.camera.width, cfg.camera.height, cfg.camera.fx, cfg.camera.fy)
            != (ggcnn_cfg.camera.width, ggcnn_cfg.camera.height, ggcnn_cfg.camera.fx, ggcnn_cfg.camera.fy)):
        raise ValueError("the evaluation config has another ggcnn.input_size / crop_size or camera image size "
                         "or focal length than the GG-CNN was trained with (RUN/ggcnn/config.json): it needs "
                         "the image scale it was trained on")
    return cfg


def prepare_eval(args) -> SimpleNamespace:
    """The plan of an ``eval.py`` command line, every input checked (the flags first, so a bad
    one is refused in about a second; nothing is compiled)."""
    policy, seeds, sweep_abs, sweep_q, compare = _check_flags(args)
    groups = None if args.groups is None else parse_groups(args.groups)
    overrides = C.parse_overrides(args.set)
    if args.speed is not None:
        if "benchmark.speed" in overrides:
            raise ValueError("give the speed once: --speed or --set benchmark.speed=...")
        overrides["benchmark.speed"] = args.speed
    vpg_variables = vpg_step = None
    if (policy == "vags" and args.run and overrides.get("vags.gate") == "rate" and not args.no_viewpoint
            and rate_gate.load(args.run) is None):  # --no-viewpoint never moves: it needs no table
        raise ValueError(f"vags.gate=rate needs the run's measured gate table, and {args.run} has no "
                         f"{rate_gate.GATE_FILE}: measure it with python -m vags_jax.stages.gate_measure --run RUN")
    if policy == "vpg":  # VPG's own config and networks (RUN/vpg): no VPG in the run, damaged files
        run_cfg, vpg_variables, vpg_step = load_vpg(args.run, args.step)
        networks = ggcnn_params = ggcnn_cfg = None
    else:
        run_cfg, networks, ggcnn_params, ggcnn_cfg = _run_config(args, policy, overrides)
    cfg = _eval_config(args, policy, run_cfg, ggcnn_cfg, overrides)
    render.check_renderer(cfg.camera)  # the Warp renderer's GPU, before anything compiles
    rounds = cfg.benchmark.rounds if args.rounds is None else args.rounds
    groups = C.benchmark_groups(cfg) if groups is None else groups
    check_rounds_fit(cfg, rounds, len(groups))
    if args.record and args.record_rounds > rounds:
        raise ValueError(f"--record-rounds {args.record_rounds} exceeds the {rounds} rounds per group")
    if policy not in P.POLICIES:
        raise ValueError(f"unknown policy {policy!r}; choose one of {', '.join(P.POLICIES)}")
    variables, step = None, vpg_step
    if policy == "gdnet":  # the learner, checked against the run's network config
        if cfg.vags.direct_score not in P.GDNET_ALONE_SCORES:
            raise ValueError(f"--policy gdnet plans with GDNet alone: vags.direct_score must be one of "
                             f"{', '.join(P.GDNET_ALONE_SCORES)} (got {cfg.vags.direct_score!r}; the success net's "
                             f"direct grasp is --policy vags --no-viewpoint --set vags.direct_score=success)")
        _, variables, step = rundir.load_gdnet(args.run, args.step)
    if policy == "vags":  # the config's gate / close-view planner against the run's networks
        P.vags_params(networks, cfg, -math.inf if args.no_viewpoint else args.threshold)
    if policy == "nbv":  # the close-view planner against the run's networks
        P.nbv_params(networks, cfg)
    groups = E.check_groups(groups, cfg, rounds)
    time_model = M.MotionTimeModel.from_config(cfg)
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
    return SimpleNamespace(policy=policy, name=name, cfg=cfg, groups=groups, rounds=rounds, networks=networks,
                           variables=variables, vpg_variables=vpg_variables, step=step, ggcnn_params=ggcnn_params, out=out,
                           sweep_abs=sweep_abs, sweep_q=sweep_q, sweep_out=sweep_out, compare=compare, seeds=seeds,
                           time_model=time_model)


def policy_of(plan, args) -> P.Policy:
    """The policy of a checked plan (``prepare_eval``; one method of ``prepare_compare``), named
    as in its report: ``--no-viewpoint`` makes VAGS's threshold -inf, ``--threshold`` sets it."""
    threshold = -math.inf if args.no_viewpoint else args.threshold
    pol = P.make_policy(plan.policy, plan.cfg, plan.variables, plan.ggcnn_params, plan.networks, threshold,
                        vpg_variables=plan.vpg_variables)
    return dataclasses.replace(pol, name=plan.name)
