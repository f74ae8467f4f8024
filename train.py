#!/usr/bin/env python3
"""Train VAGS stage 1 (GDNet) in batched MJX worlds, or GG-CNN on grasps labelled in them.

    python train.py --config tiny --out runs/tiny          # CPU, a few minutes
    python train.py --config gpu --out runs/gpu            # one H100/H200, impl "warp"
    python train.py --config gpu --set exploration.daes=false --out runs/no_daes
    python train.py --out runs/tiny --resume               # continue exactly where it stopped
    python train.py --config tiny --stage ggcnn --out runs/tiny   # GG-CNN (vags_jax.ggcnn_stage)

Writes into --out: config.json, metrics.jsonl (one line per iteration), checkpoints/ (orbax).
--stage ggcnn makes (or reuses, from --data-dir) its physics-labelled views, trains GG-CNN,
measures its held-out grasp success in physics and writes only --out/ggcnn/ (checkpoints/,
config.json, metrics.json), so stage 1 and GG-CNN can share a run directory in either order.

Every input is checked before anything is compiled or written: a bad flag, --set value or run
directory ends with one line on stderr and exit code 2.  Nothing is written to --out until the
inputs are valid, and an --out left by a run that failed before its first checkpoint is reused.
--resume continues from the last checkpoint; only stage1.iterations may change, and only
upwards (the new total is written to config.json); a run that already reached the requested
iterations is left as it is (exit code 0 when they equal its checkpoint, 2 when fewer are
asked).  A run whose loss or Q values become non-finite stops with exit code 1, keeping the
last good state as its checkpoint.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import sys
import time
from types import SimpleNamespace

from vags_jax import cli

PROG = "train.py"
# What a run directory may hold besides its checkpoints, for --out to be reused by a fresh run
# when it has no checkpoint yet (a run that failed before its first checkpoint).
# (``ggcnn``: GG-CNN's own directory, written by --stage ggcnn, which stage 1 never reads.)
RUN_LEFTOVERS = ("config.json", "metrics.jsonl", "checkpoints", "ggcnn")
STAGES = ("gdnet", "ggcnn")
# Metrics that must stay finite; the run stops (exit code 1) when one is not.
FINITE_METRICS = ("loss", "td_abs", "q_max", "q_executed")


def parse_args(argv=None):
    p = cli.ArgumentParser(prog=PROG, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--config", default=None, help="preset: tiny | gpu | paper | default (default: tiny)")
    p.add_argument("--set", nargs="*", default=[], metavar="SECTION.FIELD=VALUE",
                   help="config overrides, e.g. stage1.iterations=200 net.trunk=small")
    p.add_argument("--out", required=True, help="run directory")
    p.add_argument("--stage", choices=STAGES, default="gdnet",
                   help="gdnet: stage 1, GDNet (default); ggcnn: GG-CNN on physics-labelled views, "
                        "written to --out/ggcnn")
    p.add_argument("--data-dir", default=None,
                   help="--stage ggcnn: where its labelled views are cached (default "
                        "~/.cache/vags_jax/ggcnn); a run with the same config reuses them")
    p.add_argument("--resume", action="store_true",
                   help="continue the run in --out from its last checkpoint (only stage1.iterations may "
                        "change, and only upwards; the new total is written to its config.json)")
    p.add_argument("--chunk", type=cli.int_in(1, 10**6), default=None,
                   help="iterations (--stage ggcnn: updates) per jitted chunk (metrics/progress/checkpoint "
                        "granularity); default: auto")
    p.add_argument("--checkpoint-every", type=cli.int_in(1, 10**6), default=None,
                   help="checkpoint every N chunks (default 1)")
    p.add_argument("--max-minutes", type=cli.positive_float(10**6), default=None,
                   help="stop (with a checkpoint) once this much wall time has passed")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    return p.parse_args(argv)


def _check_out_path(out: str) -> None:
    """--out names a directory (new or existing), not a file."""
    if not out:
        raise ValueError("--out must not be empty")
    if os.path.exists(out) and not os.path.isdir(out):
        raise ValueError(f"--out {out!r} is a file, not a directory; choose a run directory")


def _check_only_run_files(out: str) -> None:
    """An existing --out holds only what train.py and eval.py write into a run."""
    other = sorted(n for n in os.listdir(out) if not n.startswith(".") and n not in RUN_LEFTOVERS
                   and not (n.startswith("eval_") and n.endswith(".json")))
    if other:
        raise ValueError(f"--out {out!r} is a non-empty directory that is not a run of train.py "
                         f"(it holds {other[:3]}); choose a new or empty directory")


def check_fresh_out(out: str) -> None:
    """--out for a new run: a new or empty directory, or a run directory with no checkpoint yet
    (left by a run that failed before its first checkpoint: it is reused)."""
    _check_out_path(out)
    if os.path.isdir(out):
        from vags_jax import checkpoint

        steps = checkpoint.checkpoint_steps(out)
        if steps:
            raise ValueError(f"{out} already holds a run (checkpoint {steps[-1]}); pass --resume to "
                             f"continue it, or choose another --out")
        _check_only_run_files(out)
    cli._check_parent_writable(os.path.join(out, "config.json"), "--out")


def check_ggcnn_out(out: str) -> None:
    """--out for --stage ggcnn: a new or empty directory, or a run directory (stage 1's files
    are left alone) that holds no GG-CNN checkpoint yet."""
    _check_out_path(out)
    if os.path.isdir(out):
        from vags_jax import checkpoint, ggcnn_stage

        gdir = ggcnn_stage.ggcnn_dir(out)
        if os.path.exists(gdir) and not os.path.isdir(gdir):
            raise ValueError(f"{gdir} is a file, not GG-CNN's directory; move it away or choose another --out")
        steps = checkpoint.checkpoint_steps(gdir) if os.path.isdir(gdir) else []
        if steps:
            raise ValueError(f"{out} already holds a GG-CNN ({gdir}, checkpoint {steps[-1]}); choose another "
                             f"--out, or delete {gdir} to train it again")
        _check_only_run_files(out)
    cli._check_parent_writable(os.path.join(out, "ggcnn", "config.json"), "--out")


def prepare_ggcnn(args) -> SimpleNamespace:
    """--stage ggcnn: the config, --out and --data-dir, checked before anything is built."""
    from vags_jax import config as C

    if args.resume:
        raise ValueError("--resume continues a stage-1 (gdnet) run; --stage ggcnn trains GG-CNN from "
                         "the start (its labelled views are cached): drop --resume")
    given = [f for f, v in (("--checkpoint-every", args.checkpoint_every), ("--max-minutes", args.max_minutes))
             if v is not None]
    if given:
        raise ValueError(f"{' and '.join(given)} apply to --stage gdnet only; drop them for --stage ggcnn")
    overrides = C.parse_overrides(args.set)
    check_ggcnn_out(args.out)
    cfg = C.replace(C.preset(args.config or "tiny"), **overrides)
    from vags_jax import ggcnn_data, scene

    scene.build_spec(cfg)
    cam, crop = cfg.camera, cfg.ggcnn.crop_size
    if crop is not None and crop > min(cam.width, cam.height):
        raise ValueError(f"ggcnn.crop_size = {crop} exceeds the camera image ({cam.width} x {cam.height}); "
                         f"use at most {min(cam.width, cam.height)} or null (the largest centred square)")
    data_dir = args.data_dir if args.data_dir is not None else ggcnn_data.default_data_dir()
    if not data_dir:
        raise ValueError("--data-dir must not be empty")
    if os.path.exists(data_dir) and not os.path.isdir(data_dir):
        raise ValueError(f"--data-dir {data_dir!r} is a file, not a directory")
    cli._check_parent_writable(os.path.join(data_dir, "x"), "--data-dir")
    return SimpleNamespace(cfg=cfg, data_dir=data_dir)


def main_ggcnn(args) -> int:
    """--stage ggcnn: data (made or reused), training, held-out accuracy, checkpoint."""
    try:
        plan = prepare_ggcnn(args)
    except ValueError as e:
        return cli.fail(PROG, e)
    cfg = plan.cfg
    t0 = time.time()

    import jax

    from vags_jax import ggcnn_data, ggcnn_stage

    def log(msg):
        print(msg, file=sys.stderr, flush=True)

    try:
        maker = ggcnn_data.DataMaker.shared(cfg)  # e.g. an unknown shape name in scene.shapes
    except ValueError as e:
        return cli.fail(PROG, e)
    d = cfg.ggcnn_data
    log(f"training GG-CNN: {d.views} views ({d.heldout_views} held out) of {d.candidates} grasps, "
        f"{cfg.ggcnn.train_steps} updates of batch {cfg.ggcnn.batch_size}, input {cfg.ggcnn.input_size} px, "
        f"impl={cfg.sim.impl}, devices={jax.devices()}")
    try:
        data = ggcnn_data.load_or_make(cfg, maker, plan.data_dir, log)
    except OSError as e:
        return cli.fail(PROG, f"cannot write the GG-CNN data cache in {plan.data_dir} ({cli.first_line(e)}); "
                              f"pass another --data-dir")
    try:
        params, metrics = ggcnn_stage.train_ggcnn(cfg, data, ggcnn_stage.train_key(cfg),
                                                  log=None if args.quiet else log, chunk=args.chunk)
    except FloatingPointError as e:
        print(f"{PROG}: error: {e}. Stopped; nothing was saved", file=sys.stderr)
        return 1
    acc = ggcnn_stage.heldout_accuracy(cfg, maker.env, params, maker=maker, log=log)
    info = {"steps": metrics["steps"], "training": metrics, "heldout_accuracy": acc,
            "data": dict(data.info), "wall_s": round(time.time() - t0, 1)}
    gdir = ggcnn_stage.save_ggcnn(args.out, params, info, cfg)
    summary = {"stage": "ggcnn", "steps": metrics["steps"], "train_loss": metrics["train_loss"],
               "heldout_loss": metrics["heldout_loss"], **{k: acc[k] for k in (
                   "ggcnn_success", "label_peak_success", "candidate_success", "views_with_success")},
               "data_reused": data.info["reused"], "data": data.info["path"], "out": gdir,
               "wall_s": info["wall_s"]}
    print(json.dumps(summary))
    return 0


def prepare(args) -> SimpleNamespace:
    """Everything that can be checked before building or compiling anything: the config, --out,
    and with --resume the run's config.json and latest checkpoint (read into host memory and
    checked against the config).  Raises ValueError (CheckpointError) with what to fix;
    ``.done`` is a message when the run has nothing left to train."""
    from vags_jax import config as C

    overrides = C.parse_overrides(args.set)
    if not args.resume:
        check_fresh_out(args.out)
        cfg = C.replace(C.preset(args.config or "tiny"), **overrides)
        from vags_jax import scene

        scene.build_spec(cfg)  # the scene's own checks (shape names), in milliseconds
        return SimpleNamespace(cfg=cfg, step=0, arrays=None, done=None, raised_from=None)

    from vags_jax import checkpoint

    if args.config is not None:
        raise ValueError("--resume takes the run's own config.json; drop --config")
    bad = [k for k in overrides if k != "stage1.iterations"]
    if bad:
        raise ValueError(f"with --resume only stage1.iterations may change (the run's config.json fixes "
                         f"the rest), got {bad}; start a new run (another --out) to change them")
    if not os.path.isdir(args.out):
        raise ValueError(f"run directory {args.out!r} does not exist; drop --resume to start a new run there")
    run_cfg = checkpoint.load_config(args.out)
    cfg = C.replace(run_cfg, **overrides)
    steps = checkpoint.checkpoint_steps(args.out)
    if not steps:
        raise ValueError(f"{args.out} has no checkpoint yet (the run stopped before its first one); "
                         f"start it again without --resume (the directory is reused)")
    step, total = steps[-1], cfg.stage1.iterations
    asked = "stage1.iterations" in overrides
    if total < step:
        raise ValueError(f"{args.out} is already at iteration {step}: the requested stage1.iterations={total} "
                         f"are already done, so there is nothing to train (config.json unchanged); "
                         f"pass stage1.iterations > {step} to train further, or evaluate it with "
                         f"eval.py --run {args.out}")
    if total == step:
        done = (f"{args.out} is already at iteration {step} of {total}: nothing to train (config.json "
                f"unchanged); pass --set stage1.iterations=N with N > {step} to train further")
        return SimpleNamespace(cfg=cfg, step=step, arrays=None, done=done, raised_from=None)
    check_metrics_file(args.out)
    arrays, step = checkpoint.read(args.out, step)
    from vags_jax import stages

    checkpoint.check_layout(args.out, step, arrays, stages.checkpoint_layout(cfg))
    saved_it = int(arrays["iteration"]["00000"])  # check_layout found the one () int32 leaf
    if saved_it != step:
        raise checkpoint.CheckpointError(
            f"checkpoint {step} in {args.out} holds iteration {saved_it}, not {step}: it was not "
            f"written by train.py for this run; start a new run")
    raised = run_cfg.stage1.iterations if asked and total != run_cfg.stage1.iterations else None
    return SimpleNamespace(cfg=cfg, step=step, arrays=arrays, done=None, raised_from=raised)


def check_metrics_file(run_dir: str) -> None:
    """metrics.jsonl of a run to resume: every line a JSON object with an "iteration"."""
    path = os.path.join(run_dir, "metrics.jsonl")
    if not os.path.exists(path):
        return
    n = 0
    try:
        with open(path, encoding="utf-8") as f:
            for n, line in enumerate(f, 1):
                if line.strip() and not isinstance(json.loads(line).get("iteration"), int):
                    raise ValueError('no "iteration"')
    except (OSError, UnicodeDecodeError, ValueError, AttributeError) as e:
        raise ValueError(f"{path} is damaged at line {n} ({cli.first_line(e)}); delete that line "
                         f"(or the file, losing the logged curves) and resume again") from None


def nonfinite(metrics: dict, first_iteration: int):
    """A message naming the first iteration whose loss / Q values are not finite, else None.
    ``metrics``: {name: (n,) array} of one chunk starting at ``first_iteration``."""
    import numpy as np

    for k in range(len(next(iter(metrics.values())))):
        bad = [name for name in FINITE_METRICS if name in metrics
               and not math.isfinite(float(np.asarray(metrics[name])[k]))]
        if bad:
            return (f"{' and '.join(bad)} became non-finite at iteration {first_iteration + k} "
                    f"({', '.join(f'{n} = {float(np.asarray(metrics[n])[k])}' for n in bad)}): the "
                    f"learning diverged (a resume would repeat it exactly); start a new run with a "
                    f"lower dqn.learning_rate or dqn.optimizer=adam")
    return None


def progress_line(it, total, grasps, recent_success, eps, loss, rate, explored):
    width = 24
    done = int(width * it / max(total, 1))
    return (f"\r[{'#' * done}{'.' * (width - done)}] {it}/{total} it | {grasps} grasps | "
            f"success {100 * recent_success:5.1f}% | eps {eps:.3f} | explored {100 * explored:4.1f}% | "
            f"loss {loss:.4f} | {rate:7.1f} grasps/s")


def main(argv=None) -> int:
    args = parse_args(argv)  # bad flags: one line, exit code 2
    if args.stage == "ggcnn":
        return main_ggcnn(args)
    if args.data_dir is not None:
        return cli.fail(PROG, "--data-dir is for --stage ggcnn (its cached views); drop it for stage 1")
    if args.checkpoint_every is None:
        args.checkpoint_every = 1
    try:
        plan = prepare(args)
    except ValueError as e:  # config validation / CheckpointError: what to fix
        return cli.fail(PROG, e)
    if plan.done:
        print(plan.done, file=sys.stderr)
        return 0
    cfg = plan.cfg

    import jax
    import numpy as np

    from vags_jax import checkpoint, stages

    try:
        stage = stages.make_stage1(cfg)  # e.g. an unknown shape name in scene.shapes
    except ValueError as e:
        return cli.fail(PROG, e)
    state = stage.init(jax.random.PRNGKey(cfg.seed))
    start_it = 0
    if args.resume:
        try:
            state = checkpoint.fit(args.out, plan.step, state, plan.arrays)
        except checkpoint.CheckpointError as e:
            return cli.fail(PROG, e)
        plan.arrays = None
        start_it = plan.step
        print(f"resumed {args.out} at iteration {start_it}", file=sys.stderr)
        if plan.raised_from is not None:
            print(f"stage1.iterations {plan.raised_from} -> {cfg.stage1.iterations} (written to "
                  f"{os.path.join(args.out, checkpoint.CONFIG_FILE)})", file=sys.stderr)
    else:  # a run directory with no checkpoint (a failed start) is reused: clear what it left
        leftover = os.path.join(args.out, checkpoint.CHECKPOINT_DIR)
        if os.path.isdir(leftover):
            shutil.rmtree(leftover)

    # Inputs are valid and the state is built: only now is anything written to --out.
    checkpoint.save_config(args.out, cfg)
    total = cfg.stage1.iterations
    chunk = args.chunk or max(1, min(50, total // 10 or 1))
    metrics_path = os.path.join(args.out, "metrics.jsonl")
    if not args.resume and os.path.exists(metrics_path):
        os.remove(metrics_path)
    if args.resume and os.path.exists(metrics_path):  # drop lines past the checkpoint
        with open(metrics_path) as f:
            lines = [l for l in f if l.strip() and json.loads(l)["iteration"] < start_it]
        with open(metrics_path, "w") as f:
            f.writelines(lines)

    t0 = time.time()
    it, n_chunks, recent = start_it, 0, []
    saved_it = start_it if args.resume else None
    grasps_done = int(jax.device_get(state.attempts))
    print(f"training stage 1 (GDNet): {cfg.stage1.n_worlds} worlds, {total} iterations, "
          f"impl={cfg.sim.impl}, trunk={cfg.net.trunk}, daes={cfg.exploration.daes}, "
          f"devices={jax.devices()}", file=sys.stderr)
    while it < total:
        n = min(chunk, total - it)
        tc = time.time()
        good = state  # the last state whose losses and Q values were finite
        state, m = stage.run(state, n)
        m = jax.device_get(m)
        dt = time.time() - tc
        with open(metrics_path, "a") as f:
            for k in range(n):
                row = {key: float(np.asarray(v)[k]) for key, v in m.items()}
                row["iteration"] = it + k
                row["grasp_attempts"] = int(row["attempts_total"])
                row["wall_s"] = round(time.time() - t0, 3)
                f.write(json.dumps(row) + "\n")
        diverged = nonfinite(m, it)
        if diverged:
            if saved_it != it:  # keep the last good state as a checkpoint
                checkpoint.save(args.out, it, good)
                saved_it = it
            if not args.quiet:
                print(file=sys.stderr)
            print(f"{PROG}: error: {diverged}. Stopped; the last good checkpoint is iteration {saved_it} "
                  f"in {os.path.join(args.out, checkpoint.CHECKPOINT_DIR)}", file=sys.stderr)
            return 1
        it += n
        n_chunks += 1
        n_att = float(np.sum(m["attempts"]))
        grasps_done = int(m["attempts_total"][-1])
        recent = (recent + list(np.asarray(m["success_rate"])))[-max(10, chunk):]
        if not args.quiet:
            print(progress_line(it, total, grasps_done, float(np.mean(recent)), float(m["epsilon"][-1]),
                                float(m["loss"][-1]), n_att / dt,
                                float(np.mean(m["explored"]))), end="", file=sys.stderr, flush=True)
        out_of_time = args.max_minutes is not None and time.time() - t0 > 60 * args.max_minutes
        if n_chunks % args.checkpoint_every == 0 or it >= total or out_of_time:
            checkpoint.save(args.out, it, state)
            saved_it = it
        if out_of_time:
            print(f"\nstopped after {args.max_minutes} min at iteration {it}; --resume continues",
                  file=sys.stderr)
            break
    if not args.quiet:
        print(file=sys.stderr)
    summary = {"iterations": it, "grasp_attempts": grasps_done,
               "recent_success_rate": float(np.mean(recent)) if recent else None,
               "wall_s": round(time.time() - t0, 1), "out": args.out}
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
