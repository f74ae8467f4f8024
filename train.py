#!/usr/bin/env python3
"""Train VAGS in batched MJX worlds: GG-CNN, then stage 1 (GDNet), stage 2 (VANet, GDNet frozen)
and stage 3 (both, alternating) -- the whole pipeline with no --stage, or one stage.

    python train.py --config tiny --out runs/tiny          # the whole pipeline, CPU, minutes
    python train.py --config gpu --out runs/gpu            # one H100/H200, impl "warp"
    python train.py --out runs/gpu --resume                # continue wherever it stopped
    python train.py --config tiny --stage gdnet --out runs/s1      # stage 1 only (GDNet)
    python train.py --config tiny --stage ggcnn --out runs/s1      # GG-CNN only, into a run
    python train.py --out runs/s1 --stage stage2           # stage 2 of an existing run
    python train.py --config gpu --stage gdnet --set exploration.daes=false --out runs/no_daes

Stages (--stage): ggcnn; stage1 (alias gdnet); stage2 (alias vanet); stage3 (alias alternate).
Writes into --out: config.json; stage 1's metrics.jsonl and checkpoints/ (orbax); ggcnn/
(checkpoints/, config.json, metrics.json); stage2/ and stage3/ (checkpoints/, metrics.jsonl);
timings.jsonl (wall-clock of every stage segment).  Every metrics row names its stage.
Stage 2 starts from stage 1's final GDNet and the run's GG-CNN; stage 3 from stage 2's final
networks and decision threshold.  GG-CNN's labelled views are cached (--data-dir), so a
pipeline stopped inside GG-CNN's training trains it again from the cached views.

Every input is checked before anything is compiled or written: a bad flag, --set value or run
directory ends with one line on stderr and exit code 2.  Nothing is written to --out until the
inputs are valid, and an --out left by a run that failed before its first checkpoint is reused.
--resume continues from the last checkpoint of the first unfinished stage; only
stage1/2/3.iterations may change, and only for stages that have not been built on (the new
totals are written to config.json).  --max-minutes stops (with a checkpoint) once that much
time has passed, inside or between stages.  A run whose loss or Q values become non-finite
stops with exit code 1, keeping the last good state as its checkpoint.
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
RUN_LEFTOVERS = ("config.json", "metrics.jsonl", "checkpoints", "ggcnn", "stage2", "stage3", "timings.jsonl")
STAGES = ("ggcnn", "stage1", "stage2", "stage3", "gdnet", "vanet", "alternate")
# Stage 1's metrics that must stay finite; the run stops (exit code 1) when one is not.
FINITE_METRICS = ("loss", "td_abs", "q_max", "q_executed")
ITERATION_KEYS = ("stage1.iterations", "stage2.iterations", "stage3.iterations")


def parse_args(argv=None):
    p = cli.ArgumentParser(prog=PROG, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--config", default=None, help="preset: tiny | gpu | gpu-edge | paper | default (default: tiny)")
    p.add_argument("--set", nargs="*", default=[], metavar="SECTION.FIELD=VALUE",
                   help="config overrides, e.g. stage1.iterations=200 net.trunk=small")
    p.add_argument("--out", required=True, help="run directory")
    p.add_argument("--stage", choices=STAGES, default=None,
                   help="one stage only: ggcnn (GG-CNN, into --out/ggcnn), stage1 = gdnet (GDNet), "
                        "stage2 = vanet (VANet, GDNet frozen; needs stage 1 and GG-CNN in --out), "
                        "stage3 = alternate (both; needs stage 2).  Default: the whole pipeline")
    p.add_argument("--data-dir", default=None,
                   help="GG-CNN's labelled views are cached here (default ~/.cache/vags_jax/ggcnn); a run "
                        "with the same config reuses them")
    p.add_argument("--resume", action="store_true",
                   help="continue the run in --out from its last checkpoint (only stage1/2/3.iterations may "
                        "change; the new totals are written to its config.json)")
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
                   and not n.startswith("eval_"))
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
    check_ggcnn_config(cfg)
    return SimpleNamespace(cfg=cfg, data_dir=check_data_dir(args.data_dir))


def check_ggcnn_config(cfg) -> None:
    """The scene's own checks and GG-CNN's crop against the camera image."""
    from vags_jax import scene

    scene.build_spec(cfg)
    cam, crop = cfg.camera, cfg.ggcnn.crop_size
    if crop is not None and crop > min(cam.width, cam.height):
        raise ValueError(f"ggcnn.crop_size = {crop} exceeds the camera image ({cam.width} x {cam.height}); "
                         f"use at most {min(cam.width, cam.height)} or null (the largest centred square)")


def check_data_dir(data_dir) -> str:
    """--data-dir (default: GG-CNN's cache directory), checked writable -> the path."""
    from vags_jax import ggcnn_data

    data_dir = data_dir if data_dir is not None else ggcnn_data.default_data_dir()
    if not data_dir:
        raise ValueError("--data-dir must not be empty")
    if os.path.exists(data_dir) and not os.path.isdir(data_dir):
        raise ValueError(f"--data-dir {data_dir!r} is a file, not a directory")
    cli._check_parent_writable(os.path.join(data_dir, "x"), "--data-dir")
    return data_dir


def main_ggcnn(args) -> int:
    """--stage ggcnn: data (made or reused), training, held-out accuracy, checkpoint."""
    try:
        plan = prepare_ggcnn(args)
    except ValueError as e:
        return cli.fail(PROG, e)
    code, summary = train_ggcnn_into(plan.cfg, args.out, plan.data_dir, args.quiet, args.chunk)
    if summary is not None:
        print(json.dumps(summary))
    return code


def _log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def train_ggcnn_into(cfg, out: str, data_dir: str, quiet: bool, chunk=None):
    """GG-CNN's data (made or reused from ``data_dir``), training, held-out accuracy and
    checkpoint into ``out``/ggcnn -> (exit code, summary dict or None)."""
    t0 = time.time()

    import jax

    from vags_jax import ggcnn_data, ggcnn_stage

    try:
        maker = ggcnn_data.DataMaker.shared(cfg)  # e.g. an unknown shape name in scene.shapes
    except ValueError as e:
        return cli.fail(PROG, e), None
    d = cfg.ggcnn_data
    _log(f"training GG-CNN: {d.views} views ({d.heldout_views} held out) of {d.candidates} grasps, "
         f"{cfg.ggcnn.train_steps} updates of batch {cfg.ggcnn.batch_size}, input {cfg.ggcnn.input_size} px, "
         f"impl={cfg.sim.impl}, devices={jax.devices()}")
    try:
        data = ggcnn_data.load_or_make(cfg, maker, data_dir, _log)
    except OSError as e:
        return cli.fail(PROG, f"cannot write the GG-CNN data cache in {data_dir} ({cli.first_line(e)}); "
                              f"pass another --data-dir"), None
    try:
        params, metrics = ggcnn_stage.train_ggcnn(cfg, data, ggcnn_stage.train_key(cfg),
                                                  log=None if quiet else _log, chunk=chunk)
    except FloatingPointError as e:
        print(f"{PROG}: error: {e}. Stopped; nothing was saved", file=sys.stderr)
        return 1, None
    acc = ggcnn_stage.heldout_accuracy(cfg, maker.env, params, maker=maker, log=_log)
    info = {"steps": metrics["steps"], "training": metrics, "heldout_accuracy": acc,
            "data": dict(data.info), "wall_s": round(time.time() - t0, 1)}
    gdir = ggcnn_stage.save_ggcnn(out, params, info, cfg)
    summary = {"stage": "ggcnn", "steps": metrics["steps"], "train_loss": metrics["train_loss"],
               "heldout_loss": metrics["heldout_loss"], **{k: acc[k] for k in (
                   "ggcnn_success", "label_peak_success", "candidate_success", "views_with_success")},
               "data_reused": data.info["reused"], "data": data.info["path"], "out": gdir,
               "wall_s": info["wall_s"]}
    return 0, summary


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
        check_net_init(cfg)
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
    arrays = read_stage1_checkpoint(args.out, cfg, step)
    raised = run_cfg.stage1.iterations if asked and total != run_cfg.stage1.iterations else None
    if raised is not None:
        check_not_built_on(args.out, "stage1")
    return SimpleNamespace(cfg=cfg, step=step, arrays=arrays, done=None, raised_from=raised)


def check_net_init(cfg) -> None:
    """net.init (ImageNet DenseNet-121 weights) read and checked against the trunks before
    anything is compiled; ValueError saying what to fix."""
    if cfg.net.init is None:
        return
    from vags_jax.networks import check_init, make_qnet

    H = cfg.workspace.heightmap_px
    check_init(cfg.net, make_qnet(cfg.net, "gdnet"), H, H)


def read_stage1_checkpoint(out: str, cfg, step: int) -> dict:
    """Stage 1's checkpoint ``step`` read into host memory and checked against the config
    (before anything is compiled) -> its arrays for ``checkpoint.fit``."""
    from vags_jax import checkpoint, stages

    arrays, step = checkpoint.read(out, step)
    checkpoint.check_layout(out, step, arrays, stages.checkpoint_layout(cfg))
    saved_it = int(arrays["iteration"]["00000"])  # check_layout found the one () int32 leaf
    if saved_it != step:
        raise checkpoint.CheckpointError(
            f"checkpoint {step} in {out} holds iteration {saved_it}, not {step}: it was not "
            f"written by train.py for this run; start a new run")
    return arrays


def check_not_built_on(out: str, name: str) -> None:
    """A stage's iterations may change only while no later stage has started from its end."""
    from vags_jax import pipeline

    later = pipeline.ORDER[pipeline.ORDER.index(name) + 1:]
    started = [n for n in later if n != "ggcnn" and pipeline.progress(out, n) > 0]
    if started:
        raise ValueError(f"{pipeline.DESCRIPTION[started[0]]} in {out} already started from the end of "
                         f"{pipeline.DESCRIPTION[name]}: {name}.iterations can no longer change; start a "
                         f"new run (another --out) to train {name} longer")


def check_metrics_file(run_dir: str) -> None:
    """metrics.jsonl of a run (stage) to resume: every line a JSON object with an "iteration"."""
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


def nonfinite(metrics: dict, first_iteration: int, names=FINITE_METRICS):
    """A message naming the first iteration whose loss / Q values are not finite, else None.
    ``metrics``: {name: (n,) array} of one chunk starting at ``first_iteration``."""
    import numpy as np

    for k in range(len(next(iter(metrics.values())))):
        bad = [name for name in names if name in metrics
               and not math.isfinite(float(np.asarray(metrics[name])[k]))]
        if bad:
            return (f"{' and '.join(bad)} became non-finite at iteration {first_iteration + k} "
                    f"({', '.join(f'{n} = {float(np.asarray(metrics[n])[k])}' for n in bad)}): the "
                    f"learning diverged (a resume would repeat it exactly); start a new run with a "
                    f"lower dqn.learning_rate or dqn.optimizer=adam")
    return None


def progress_line(stage, it, total, grasps, recent_success, eps, loss, rate, explored, view_share=None):
    width = 24
    done = int(width * it / max(total, 1))
    view = "" if view_share is None else f"view {100 * view_share:4.1f}% | "
    return (f"\r{stage} [{'#' * done}{'.' * (width - done)}] {it}/{total} it | {grasps} grasps | "
            f"success {100 * recent_success:5.1f}% | {view}eps {eps:.3f} | explored {100 * explored:4.1f}% | "
            f"loss {loss:.4f} | {rate:7.1f} grasps/s")


def _trim_metrics(metrics_path: str, start_it: int) -> None:
    """Drops the metrics rows at or past ``start_it`` (all of them for a fresh start)."""
    if not os.path.exists(metrics_path):
        return
    if start_it == 0:
        os.remove(metrics_path)
        return
    with open(metrics_path) as f:
        lines = [l for l in f if l.strip() and json.loads(l)["iteration"] < start_it]
    with open(metrics_path, "w") as f:
        f.writelines(lines)


def run_chunks(name: str, stage, state, start_it: int, total: int, out_dir: str, args, deadline,
               finite=FINITE_METRICS, loss_key: str = "loss", on_save=None):
    """Advances a stage's state chunk by chunk from ``start_it`` to ``total`` iterations,
    logging every iteration to ``out_dir``/metrics.jsonl (with ``"stage": name``), checkpointing
    into ``out_dir`` and stopping at ``deadline`` (a time.time() value, or None).
    Returns (state, iteration reached, status, grasps, recent success): status is "done",
    "out_of_time" or an error message (the learning diverged; the last good state is saved).
    ``on_save(it, state)`` runs after every checkpoint of a good state."""
    import jax
    import numpy as np

    from vags_jax import checkpoint

    metrics_path = os.path.join(out_dir, "metrics.jsonl")
    _trim_metrics(metrics_path, start_it)
    chunk = args.chunk or max(1, min(50, total // 10 or 1))
    every = args.checkpoint_every or 1
    t0 = time.time()
    it, n_chunks, recent = start_it, 0, []
    saved_it = start_it if start_it > 0 else None
    grasps_done = int(jax.device_get(state.attempts))
    status = "done"
    while it < total:
        n = min(chunk, total - it)
        tc = time.time()
        good = state  # the last state whose losses and Q values were finite
        state, m = stage.run(state, n)
        m = jax.device_get(m)
        dt = time.time() - tc
        with open(metrics_path, "a") as f:
            for k in range(n):
                row = {"stage": name, **{key: float(np.asarray(v)[k]) for key, v in m.items()}}
                row["iteration"] = it + k
                row["grasp_attempts"] = int(row["attempts_total"])
                row["wall_s"] = round(time.time() - t0, 3)
                f.write(json.dumps(row) + "\n")
        diverged = nonfinite(m, it, finite)
        if diverged:
            if saved_it != it and not getattr(stage, "donates", False):  # keep the last good state
                checkpoint.save(out_dir, it, good)
                saved_it = it
            if not args.quiet:
                print(file=sys.stderr)
            return good, it, (f"{diverged}. Stopped; the last good checkpoint is iteration {saved_it} in "
                              f"{os.path.join(out_dir, checkpoint.CHECKPOINT_DIR)}"), grasps_done, None
        it += n
        n_chunks += 1
        n_att = float(np.sum(m["attempts"]))
        grasps_done = int(m["attempts_total"][-1])
        recent = (recent + list(np.asarray(m["success_rate"])))[-max(10, chunk):]
        if not args.quiet:
            print(progress_line(name, it, total, grasps_done, float(np.mean(recent)), float(m["epsilon"][-1]),
                                float(m[loss_key][-1]), n_att / dt, float(np.mean(m["explored"])),
                                float(np.mean(m["view_share"])) if "view_share" in m else None),
                  end="", file=sys.stderr, flush=True)
        out_of_time = deadline is not None and time.time() > deadline
        if n_chunks % every == 0 or it >= total or out_of_time:
            checkpoint.save(out_dir, it, state)
            saved_it = it
            if on_save is not None:
                on_save(it, state)
        if out_of_time and it < total:
            status = "out_of_time"
            break
    if not args.quiet:
        print(file=sys.stderr)
    return state, it, status, grasps_done, float(np.mean(recent)) if recent else None


def log_timing(out: str, name: str, start_it: int, it: int, wall_s: float, status: str) -> None:
    """Appends one stage segment's wall-clock to ``out``/timings.jsonl."""
    with open(os.path.join(out, "timings.jsonl"), "a") as f:
        f.write(json.dumps({"stage": name, "from": start_it, "to": it, "wall_s": round(wall_s, 1),
                            "status": status, "time": time.strftime("%Y-%m-%dT%H:%M:%S")}) + "\n")


# Stages (and their environment) built in this process, by config: a second train.main() call
# in one process (a test, a notebook) reuses their compiled programs instead of tracing and
# compiling them again.  The iteration counts do not enter the programs, so they are not part
# of the key.
_BUILT: dict = {}


def built(kind: str, cfg, make):
    """The ``kind`` object ("env", "stage1", "stage2", "stage3") built for ``cfg``, made by
    ``make()`` the first time."""
    from vags_jax import config as C

    key = (kind, C.replace(cfg, **{f"stage{n}.iterations": 1 for n in (1, 2, 3)}))
    if key not in _BUILT:
        _BUILT[key] = make()
    return _BUILT[key]


def _env(cfg):
    from vags_jax.env import VagsEnv

    return VagsEnv(cfg)


def end_of_segment(args, name: str, start_it: int, it: int, t0: float, status: str) -> bool:
    """Logs a stage segment's wall clock (timings.jsonl) and says how it ended; True when the
    learning diverged (``status`` is then the message)."""
    ok = status in ("done", "out_of_time")
    log_timing(args.out, name, start_it, it, time.time() - t0, status if ok else "diverged")
    if not ok:
        print(f"{PROG}: error: {status}", file=sys.stderr)
    elif status == "out_of_time":
        print(f"stopped after {args.max_minutes} min at {name} iteration {it}; --resume continues", file=sys.stderr)
    return not ok


def main(argv=None) -> int:
    args = parse_args(argv)  # bad flags: one line, exit code 2
    from vags_jax import pipeline

    stage = pipeline.canonical(args.stage) if args.stage else None
    if stage == "ggcnn":
        return main_ggcnn(args)
    if stage == "stage1":
        if args.data_dir is not None:
            return cli.fail(PROG, "--data-dir is for GG-CNN (--stage ggcnn, or the whole pipeline); drop it "
                                  "for --stage gdnet")
        return main_stage1(args)
    return main_pipeline(args, stage)


def main_stage1(args) -> int:
    """--stage gdnet (stage1): stage 1 only, fresh or resumed."""
    try:
        plan = prepare(args)
    except ValueError as e:  # config validation / CheckpointError: what to fix
        return cli.fail(PROG, e)
    if plan.done:
        print(plan.done, file=sys.stderr)
        return 0
    cfg = plan.cfg

    from vags_jax import checkpoint

    if not args.resume:  # a run directory with no checkpoint (a failed start) is reused: clear what it left
        leftover = os.path.join(args.out, checkpoint.CHECKPOINT_DIR)
        if os.path.isdir(leftover):
            shutil.rmtree(leftover)
    else:
        check_metrics_file(args.out)
    t0 = time.time()
    deadline = None if args.max_minutes is None else t0 + 60 * args.max_minutes
    res = run_stage1(cfg, args, plan, deadline)
    if isinstance(res, int):
        return res
    return 0


def run_stage1(cfg, args, plan, deadline, env=None):
    """Builds (or restores, from ``plan.arrays`` at ``plan.step``) stage 1 and trains it to
    stage1.iterations -> summary dict, or an exit code."""
    import jax

    from vags_jax import checkpoint, pipeline, stages

    t0 = time.time()
    try:
        stage = built("stage1", cfg, lambda: stages.make_stage1(cfg, env or built("env", cfg, lambda: _env(cfg))))
    except ValueError as e:
        return cli.fail(PROG, e)
    state = stage.init(pipeline.stage_key(cfg, "stage1"))
    start_it = 0
    if plan.step:
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
    # Inputs are valid and the state is built: only now is anything written to --out.
    checkpoint.save_config(args.out, cfg)
    total = cfg.stage1.iterations
    print(f"training stage 1 (GDNet): {cfg.stage1.n_worlds} worlds, {total} iterations, "
          f"impl={cfg.sim.impl}, trunk={cfg.net.trunk}, daes={cfg.exploration.daes}, "
          f"devices={jax.devices()}", file=sys.stderr)
    state, it, status, grasps, recent = run_chunks("stage1", stage, state, start_it, total, args.out, args, deadline)
    if end_of_segment(args, "stage1", start_it, it, t0, status):
        return 1
    summary = {"stage": "stage1", "iterations": it, "grasp_attempts": grasps, "recent_success_rate": recent,
               "wall_s": round(time.time() - t0, 1), "out": args.out}
    if getattr(args, "print_summary", True):
        print(json.dumps(summary))
    return summary


# ----------------------------------------------------------------------------- stages 2, 3, pipeline


def prepare_pipeline(args, only):
    """The whole pipeline (``only`` None) or stage 2 / 3 alone: config, --out, and what is left
    to train, checked before anything is built.  Raises ValueError with what to fix."""
    from vags_jax import checkpoint, pipeline
    from vags_jax import config as C

    overrides = C.parse_overrides(args.set)
    fresh = only is None and not args.resume
    if fresh:
        check_fresh_out(args.out)
        cfg = C.replace(C.preset(args.config or "tiny"), **overrides)
        check_ggcnn_config(cfg)
        check_net_init(cfg)
        if os.path.isdir(args.out):  # a GG-CNN already trained into --out with this config is reused
            why = pipeline.ggcnn_reusable(args.out, cfg)
            if why:
                raise ValueError(why)
        return SimpleNamespace(cfg=cfg, fresh=True, changed={}, data_dir=check_data_dir(args.data_dir),
                               stage1_arrays=None)
    what = "--resume" if only is None else f"--stage {only}"
    if args.config is not None:
        raise ValueError(f"{what} takes the run's own config.json; drop --config")
    allowed = ITERATION_KEYS if only is None else (f"{only}.iterations",)
    bad = [k for k in overrides if k not in allowed]
    if bad:
        raise ValueError(f"with {what} only {' / '.join(allowed)} may change (the run's config.json fixes the "
                         f"rest), got {bad}; start a new run (another --out) to change them")
    _check_out_path(args.out)
    if not os.path.isdir(args.out):
        hint = "drop --resume to start a new run there" if only is None else (
            f"train the stages before {only} first (python train.py --out {args.out} runs them all)")
        raise ValueError(f"run directory {args.out!r} does not exist; {hint}")
    run_cfg = checkpoint.load_config(args.out)
    cfg = C.replace(run_cfg, **overrides)
    if only is None and not any(pipeline.progress(args.out, n) for n in pipeline.ORDER):
        raise ValueError(f"{args.out} has no checkpoint yet (the run stopped before its first one); "
                         f"start it again without --resume (the directory is reused)")
    changed = {}
    for key in overrides:
        name = key.split(".")[0]
        old, new = getattr(run_cfg, name).iterations, getattr(cfg, name).iterations
        done = pipeline.progress(args.out, name)
        if new < done:
            raise ValueError(f"{args.out} is already at iteration {done} of {name}: the requested {key}={new} are "
                             f"already done, so there is nothing to train (config.json unchanged); pass "
                             f"{key} > {done} to train further")
        if new != old:
            check_not_built_on(args.out, name)
            changed[key] = (old, new)
    names = pipeline.ORDER if only is None else (only,)
    for name in names:
        d = pipeline.stage_dir(args.out, name)
        if name != "ggcnn" and pipeline.progress(args.out, name) > 0:
            check_metrics_file(d)
    if only is not None:  # its prerequisites: every earlier stage complete
        for name in pipeline.ORDER[:pipeline.ORDER.index(only)]:
            done, want = pipeline.progress(args.out, name), pipeline.total(cfg, name)
            if done < want:
                state = "has no checkpoint" if done == 0 else f"reached iteration {done} of {want}"
                raise ValueError(f"{only} starts from the end of {pipeline.DESCRIPTION[name]}, and {args.out} "
                                 f"{state} there: run python train.py --out {args.out} --resume (every stage "
                                 f"in order) or --stage {name} first")
    if not (pipeline.progress(args.out, "stage1") and pipeline.progress(args.out, "stage2")):
        check_net_init(cfg)  # stage 1's GDNet or stage 2's VANet still starts from net.init
    data_dir = check_data_dir(args.data_dir) if only is None and pipeline.progress(args.out, "ggcnn") == 0 else None
    if only is None and pipeline.progress(args.out, "ggcnn") == 0:
        check_ggcnn_config(cfg)
    stage1_arrays = None
    done1 = pipeline.progress(args.out, "stage1")
    if only is None and 0 < done1 < cfg.stage1.iterations:  # checked now, not after GG-CNN's minutes
        stage1_arrays = read_stage1_checkpoint(args.out, cfg, done1)
    return SimpleNamespace(cfg=cfg, fresh=False, changed=changed, data_dir=data_dir, stage1_arrays=stage1_arrays)


def run_vags_stage(cfg, args, name: str, deadline, env=None):
    """Stage 2 or 3 from its start (the previous stage's networks) or its latest checkpoint,
    trained to stageN.iterations -> summary dict, or an exit code."""
    import jax

    from vags_jax import checkpoint, pipeline, vags_stages

    t0 = time.time()
    which = int(name[-1])
    out_dir = pipeline.stage_dir(args.out, name)
    done = pipeline.progress(args.out, name)
    try:
        stage = built(name, cfg, lambda: vags_stages.VagsStage(cfg, which, env or built("env", cfg, lambda: _env(cfg))))
        gg = pipeline.ggcnn_params(args.out, cfg, name)
        if done == 0 and which == 2:
            state = stage.init(pipeline.stage_key(cfg, name), pipeline.stage1_gdnet(args.out, cfg, name), gg)
        elif done == 0:
            gd, va, su, thr = pipeline.stage2_result(args.out, cfg, name)
            state = stage.init(pipeline.stage_key(cfg, name), gd, gg, va, thr, su)
        else:  # the state's structure from placeholders, then the checkpoint's arrays
            state = stage.init(pipeline.stage_key(cfg, name), pipeline.learner_target(cfg, "gdnet"), gg,
                               pipeline.learner_target(cfg, "vanet"), 0.0, pipeline.learner_target(cfg, "gdnet"))
            state, _ = checkpoint.restore(out_dir, state, done)
            print(f"resumed {out_dir} at iteration {done}", file=sys.stderr)
    except ValueError as e:  # CheckpointError: damaged or foreign checkpoint
        return cli.fail(PROG, e)
    os.makedirs(out_dir, exist_ok=True)
    st = getattr(cfg, name)
    print(f"training {pipeline.DESCRIPTION[name]}: {st.n_worlds} worlds of {st.min_objects}-{st.max_objects} "
          f"objects, {st.iterations} iterations, decision threshold {float(state.threshold):.4f}, "
          f"devices={jax.devices()}", file=sys.stderr)
    state, it, status, grasps, recent = run_chunks(
        name, stage, state, done, st.iterations, out_dir, args, deadline, vags_stages.FINITE_METRICS, "loss_vanet",
        on_save=lambda i, s: pipeline.save_networks(args.out, name, i, s, cfg))
    if end_of_segment(args, name, done, it, t0, status):
        return 1
    return {"stage": name, "iterations": it, "grasp_attempts": grasps, "recent_success_rate": recent,
            "threshold": float(state.threshold), "wall_s": round(time.time() - t0, 1), "out": out_dir}


def main_pipeline(args, only) -> int:
    """The whole pipeline (only None: GG-CNN, stages 1, 2, 3, each from where it stopped), or
    stage 2 / 3 alone."""
    try:
        plan = prepare_pipeline(args, only)
    except ValueError as e:
        return cli.fail(PROG, e)
    cfg = plan.cfg
    from vags_jax import checkpoint, pipeline

    if plan.fresh:  # a run directory with no checkpoint (a failed start) is reused: clear what it left
        for name in ("checkpoints", "stage2", "stage3", "timings.jsonl", "metrics.jsonl"):
            path = os.path.join(args.out, name)
            if os.path.isdir(path):
                shutil.rmtree(path)
            elif os.path.exists(path):
                os.remove(path)
    checkpoint.save_config(args.out, cfg)
    for key, (old, new) in plan.changed.items():
        print(f"{key} {old} -> {new} (written to {os.path.join(args.out, checkpoint.CONFIG_FILE)})", file=sys.stderr)
    t0 = time.time()
    deadline = None if args.max_minutes is None else t0 + 60 * args.max_minutes
    args.print_summary = False
    names = pipeline.ORDER if only is None else (only,)
    summaries, env = [], None
    for name in names:
        done, want = pipeline.progress(args.out, name), pipeline.total(cfg, name)
        if done >= want:
            continue
        if deadline is not None and time.time() > deadline:
            print(f"stopped after {args.max_minutes} min before {name}; --resume continues", file=sys.stderr)
            break
        if name == "ggcnn":
            ts = time.time()
            code, summary = train_ggcnn_into(cfg, args.out, plan.data_dir, args.quiet)
            log_timing(args.out, "ggcnn", 0, 1 if code == 0 else 0, time.time() - ts, "done" if code == 0 else "error")
            if code:
                return code
        else:
            if env is None:
                from vags_jax.env import VagsEnv

                try:
                    env = built("env", cfg, lambda: VagsEnv(cfg))
                except ValueError as e:
                    return cli.fail(PROG, e)
            if name == "stage1":
                sp = SimpleNamespace(step=done, arrays=getattr(plan, "stage1_arrays", None), raised_from=None)
                plan.stage1_arrays = None
                summary = run_stage1(cfg, args, sp, deadline, env)
            else:
                summary = run_vags_stage(cfg, args, name, deadline, env)
            if isinstance(summary, int):
                return summary
        summaries.append(summary)
        if summary.get("iterations", want) < want:  # stopped by --max-minutes
            break
    status = {n: f"{pipeline.progress(args.out, n)}/{pipeline.total(cfg, n)}" for n in pipeline.ORDER}
    print(json.dumps({"stages": summaries, "progress": status, "wall_s": round(time.time() - t0, 1),
                      "out": args.out}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
