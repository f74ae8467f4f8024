"""What ``train.py`` checks before anything is built, compiled or written.

Each ``prepare_*`` takes the parsed command line (``args``: config, set, out, resume, stage,
data_dir, chunk, checkpoint_every, max_minutes, quiet, no_memory_check) and returns a plan (``SimpleNamespace``)
for ``vags_jax.stages.driver``, or raises ``ValueError`` (``CheckpointError``) with one line
saying what to fix: a bad ``--set`` value, a ``net.init`` file that is missing or does not
fit the trunks, an ``--out`` a run would damage, a damaged or foreign run directory, a
``--resume`` that would rewrite the run's config.
"""
from __future__ import annotations

import json
import os
from types import SimpleNamespace

import numpy as np

from vags_jax import cli
from vags_jax import config as C
from vags_jax.ggcnn import data as ggcnn_data
from vags_jax.nets import check_init, make_qnet
from vags_jax.parallel import mesh as parallel_mesh
from vags_jax.sim import scene
from vags_jax.perception import render
from vags_jax.stages import checkpoint, memory, run_lock, rundir, stage1
from vags_jax.stages import ggcnn as ggcnn_stage
from vags_jax.stages import vpg as vpg_stage

# What a run directory may hold besides its checkpoints, for --out to be reused by a fresh run
# when it has no checkpoint yet (a run that failed before its first checkpoint).
RUN_LEFTOVERS = ("config.json", "metrics.jsonl", "checkpoints", "ggcnn", "stage2", "stage3", "nbv", "timings.jsonl",
                 "summary.json", vpg_stage.VPG_DIR, run_lock.LOCK_FILE)
ITERATION_KEYS = ("stage1.iterations", "stage2.iterations", "stage3.iterations")


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


def check_run_writable(out: str) -> None:
    """A run to continue (--resume, --stage): it and every directory of it that training writes
    into can be written (a run copied read-only would otherwise fail at its first checkpoint)."""
    for sub in ("", "checkpoints", "stage2", "stage3", os.path.join("stage2", "checkpoints"),
                os.path.join("stage3", "checkpoints"), "ggcnn"):
        d = os.path.join(out, sub) if sub else out
        if os.path.isdir(d):
            try:
                cli.check_parent_writable(os.path.join(d, "x"), "--out")
            except ValueError:
                raise ValueError(f"--out {out!r}: cannot write in {d!r}, so the run is read-only; make it writable "
                                 f"(chmod -R u+w {out}) or copy it elsewhere to continue it") from None


def check_machine(cfg, names, args) -> None:
    """What this machine must offer the stages ``names``: the devices of data-parallel
    training (``parallel.devices``), the Warp renderer's GPU when the config asks for it, and
    the memory lower bound of ``stages.memory`` (unless --no-memory-check)."""
    if cfg.parallel.devices > 1:
        parallel_mesh.resolve(cfg.parallel.devices)  # ValueError: more than JAX sees
    render.check_renderer(cfg.camera)
    if not args.no_memory_check:
        memory.check_fits(cfg, names, memory.device_bytes())


def with_devices(args, overrides: dict, run_cfg=None) -> dict:
    """``--devices N|all`` folded into the ``--set`` overrides as ``parallel.devices`` (data-
    parallel stage 1).  ``run_cfg``: the config of a run to resume, whose device count cannot
    change (its worlds and replay are split per device): a different ``--devices`` is refused."""
    asked = getattr(args, "devices", None)
    if asked is None:
        return overrides
    n = jax_device_count() if asked == "all" else asked
    if run_cfg is not None:
        have = run_cfg.parallel.devices
        if n != have:
            raise ValueError(f"{args.out} was trained on {have} device(s) (parallel.devices = {have} in its "
                             f"config.json) and --devices asks for {n}: a run's worlds and replay are split per "
                             f"device, so its device count cannot change; resume with --devices {have} (or "
                             f"without --devices)")
        return overrides
    if overrides.get("parallel.devices", n) != n:
        raise ValueError(f"--devices {asked} and --set parallel.devices={overrides['parallel.devices']} disagree; "
                         f"give one of them")
    return {**overrides, "parallel.devices": n}


def jax_device_count() -> int:
    """Devices JAX sees (every host's with --distributed): what ``--devices all`` means."""
    return parallel_mesh.resolve("all")


def check_single_device(cfg, what: str, run: str = "") -> None:
    """Data-parallel training covers stage 1 only so far: ``what`` (the stages asked for)
    refuses a config with ``parallel.devices`` > 1; ``run``: the run directory it comes from."""
    d = cfg.parallel.devices
    if d <= 1:
        return
    if run:
        raise ValueError(f"{run} trains stage 1 data-parallel on {d} devices (parallel.devices = {d} in its "
                         f"config.json), and {what} runs on one device only so far: continue its stage 1 with "
                         f"--stage gdnet --resume; for stages 2 and 3 train a run on one device")
    raise ValueError(f"{what} runs on one device only so far, and --devices / parallel.devices asks for {d}: "
                     f"data-parallel training covers stage 1 alone (train.py --stage gdnet --devices {d}); "
                     f"drop --devices to train the whole pipeline")


def check_fresh_out(out: str) -> None:
    """--out for a new run: a new or empty directory, or a run directory with no checkpoint yet
    (left by a run that failed before its first checkpoint: it is reused)."""
    _check_out_path(out)
    if os.path.isdir(out):
        steps = checkpoint.checkpoint_steps(out)
        if steps:
            raise ValueError(f"{out} already holds a run (checkpoint {steps[-1]}); pass --resume to "
                             f"continue it, or choose another --out")
        _check_only_run_files(out)
    cli.check_parent_writable(os.path.join(out, "config.json"), "--out")


def check_ggcnn_out(out: str) -> None:
    """--out for --stage ggcnn: a new or empty directory, or a run directory (stage 1's files
    are left alone) that holds no GG-CNN checkpoint yet."""
    _check_out_path(out)
    if os.path.isdir(out):
        gdir = ggcnn_stage.ggcnn_dir(out)
        if os.path.exists(gdir) and not os.path.isdir(gdir):
            raise ValueError(f"{gdir} is a file, not GG-CNN's directory; move it away or choose another --out")
        steps = checkpoint.checkpoint_steps(gdir) if os.path.isdir(gdir) else []
        if steps:
            raise ValueError(f"{out} already holds a GG-CNN ({gdir}, checkpoint {steps[-1]}); choose another "
                             f"--out, or delete {gdir} to train it again")
        _check_only_run_files(out)
    cli.check_parent_writable(os.path.join(out, "ggcnn", "config.json"), "--out")


def prepare_ggcnn(args) -> SimpleNamespace:
    """--stage ggcnn: the config, --out and --data-dir, checked before anything is built."""
    if args.resume:
        raise ValueError("--resume continues a stage-1 (gdnet) run; --stage ggcnn trains GG-CNN from "
                         "the start (its labelled views are cached): drop --resume")
    given = [f for f, v in (("--checkpoint-every", args.checkpoint_every),
                            ("--checkpoint-minutes", getattr(args, "checkpoint_minutes", None)),
                            ("--max-minutes", args.max_minutes), ("--devices", getattr(args, "devices", None)))
             if v is not None]
    if given:
        raise ValueError(f"{' and '.join(given)} apply to --stage gdnet only; drop them for --stage ggcnn")
    overrides = C.parse_overrides(args.set)
    check_ggcnn_out(args.out)
    cfg = C.replace(C.preset("tiny" if args.config is None else args.config), **overrides)
    check_ggcnn_config(cfg)
    render.check_renderer(cfg.camera)
    return SimpleNamespace(cfg=cfg, data_dir=check_data_dir(args.data_dir))


def check_ggcnn_config(cfg) -> None:
    """The scene's own checks and GG-CNN's crop against the camera image."""
    scene.build_spec(cfg)
    cam, crop = cfg.camera, cfg.ggcnn.crop_size
    if crop is not None and crop > min(cam.width, cam.height):
        raise ValueError(f"ggcnn.crop_size = {crop} exceeds the camera image ({cam.width} x {cam.height}); "
                         f"use at most {min(cam.width, cam.height)} or null (the largest centred square)")


def check_data_dir(data_dir) -> str:
    """--data-dir (default: GG-CNN's cache directory), checked writable -> the path."""
    data_dir = data_dir if data_dir is not None else ggcnn_data.default_data_dir()
    if not data_dir:
        raise ValueError("--data-dir must not be empty")
    if os.path.exists(data_dir) and not os.path.isdir(data_dir):
        raise ValueError(f"--data-dir {data_dir!r} is a file, not a directory")
    cli.check_parent_writable(os.path.join(data_dir, "x"), "--data-dir")
    return data_dir



def check_trainable_gate(cfg) -> None:
    """A "rate" gate needs the table train.py measures after stage 3 (stage 3 itself decides
    with the "success" gate: ``stage23.training_config``)."""
    if cfg.vags.gate == "rate" and cfg.gate_table.worlds == 0:
        raise ValueError("vags.gate=rate needs the table train.py measures after stage 3, but gate_table.worlds=0 "
                         "skips it: set gate_table.worlds to at least 1 (default 256), or train with "
                         "vags.gate=success")


def prepare_stage1(args) -> SimpleNamespace:
    """Everything that can be checked before building or compiling anything: the config, --out,
    and with --resume the run's config.json and latest checkpoint (read into host memory and
    checked against the config).  Raises ValueError (CheckpointError) with what to fix;
    ``.done`` is a message when the run has nothing left to train."""
    overrides = C.parse_overrides(args.set)
    if not args.resume:
        check_fresh_out(args.out)
        overrides = with_devices(args, overrides)
        cfg = C.replace(C.preset("tiny" if args.config is None else args.config), **overrides)
        scene.build_spec(cfg)  # the scene's own checks (shape names), in milliseconds
        check_trainable_gate(cfg)
        check_net_init(cfg)
        check_machine(cfg, ("stage1",), args)
        return SimpleNamespace(cfg=cfg, step=0, arrays=None, done=None, raised_from=None)

    if args.config is not None:
        raise ValueError("--resume takes the run's own config.json; drop --config")
    bad = [k for k in overrides if k != "stage1.iterations"]
    if bad:
        raise ValueError(f"with --resume only stage1.iterations may change (the run's config.json fixes "
                         f"the rest), got {bad}; start a new run (another --out) to change them")
    if not os.path.isdir(args.out):
        raise ValueError(f"run directory {args.out!r} does not exist; drop --resume to start a new run there")
    run_cfg = checkpoint.load_config(args.out)
    cfg = C.replace(run_cfg, **with_devices(args, overrides, run_cfg))
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
    check_run_writable(args.out)
    check_machine(cfg, ("stage1",), args)
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
    H = cfg.workspace.heightmap_px
    check_init(cfg.net, make_qnet(cfg.net, "gdnet"), H, H)


def check_vags_checkpoint(out: str, cfg, name: str, step: int) -> None:
    """Stage 2 / 3's (or NBV's) checkpoint ``step`` against the config, from its metadata alone:
    its learners (GDNet, VANet or NBV's network, the success net) and the gate's calibration.
    CheckpointError (one line, another config) before anything is built or compiled."""
    gd = rundir.learner_target(cfg, "gdnet")
    want = {"gdnet": gd, "vanet": rundir.learner_target(cfg, "nbv" if name == "nbv" else "vanet"), "success": gd,
            "calibration": np.zeros((3,), np.float32)}
    checkpoint.check_parts(rundir.stage_dir(out, name), step, want)


def read_stage1_checkpoint(out: str, cfg, step: int) -> dict:
    """Stage 1's checkpoint ``step`` read into host memory and checked against the config
    (before anything is compiled) -> its arrays for ``checkpoint.fit``."""
    arrays, step = checkpoint.read(out, step)
    checkpoint.check_layout(out, step, arrays, stage1.checkpoint_layout(cfg))
    saved_it = int(arrays["iteration"]["00000"])  # check_layout found the one () int32 leaf
    if saved_it != step:
        raise checkpoint.CheckpointError(
            f"checkpoint {step} in {out} holds iteration {saved_it}, not {step}: it was not "
            f"written by train.py for this run; start a new run")
    return arrays


def check_not_built_on(out: str, name: str) -> None:
    """A stage's iterations may change only while no later stage has started from its end."""
    if name not in rundir.ORDER:  # a baseline's stage: nothing starts from it
        return
    later = rundir.ORDER[rundir.ORDER.index(name) + 1:]
    started = [n for n in later if n != "ggcnn" and rundir.progress(out, n) > 0]
    if started:
        raise ValueError(f"{rundir.DESCRIPTION[started[0]]} in {out} already started from the end of "
                         f"{rundir.DESCRIPTION[name]}: {name}.iterations can no longer change; start a "
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



def _prepare_fresh_pipeline(args, overrides) -> SimpleNamespace:
    """``prepare_pipeline`` for a new run in ``args.out``: the preset with ``overrides``, checked."""
    check_fresh_out(args.out)
    cfg = C.replace(C.preset("tiny" if args.config is None else args.config), **with_devices(args, overrides))
    check_single_device(cfg, "the whole pipeline (GG-CNN, stages 2 and 3)")
    scene.build_spec(cfg)  # the scene's own checks (an unknown shape), before anything is written
    check_trainable_gate(cfg)
    if rundir.needs_ggcnn(cfg):
        check_ggcnn_config(cfg)
    check_net_init(cfg)
    check_machine(cfg, rundir.ORDER, args)
    if os.path.isdir(args.out):  # a GG-CNN already trained into --out with this config is reused
        why = rundir.ggcnn_reusable(args.out, cfg)
        if why:
            raise ValueError(why)
    return SimpleNamespace(cfg=cfg, fresh=True, changed={}, data_dir=check_data_dir(args.data_dir),
                           stage1_arrays=None)


def _changed_iterations(out: str, run_cfg, cfg, overrides) -> dict:
    """The ``*.iterations`` overrides of a resumed run that change its config -> {key: (old, new)};
    ValueError for one below the iterations done, or for a stage a later stage already built on."""
    changed = {}
    for key in overrides:
        name = key.split(".")[0]
        old, new = getattr(run_cfg, name).iterations, getattr(cfg, name).iterations
        done = rundir.progress(out, name)
        if new < done:
            raise ValueError(f"{out} is already at iteration {done} of {name}: the requested {key}={new} are "
                             f"already done, so there is nothing to train (config.json unchanged); pass "
                             f"{key} > {done} to train further")
        if new != old:
            check_not_built_on(out, name)
            changed[key] = (old, new)
    return changed


def prepare_pipeline(args, only):
    """The whole pipeline (``only`` None) or stage 2 / 3 alone: config, --out, and what is left
    to train, checked before anything is built.  Raises ValueError with what to fix."""
    overrides = C.parse_overrides(args.set)
    if only is None and not args.resume:
        return _prepare_fresh_pipeline(args, overrides)
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
    cfg = C.replace(run_cfg, **with_devices(args, overrides, run_cfg))
    check_single_device(cfg, "the pipeline (GG-CNN, stages 2 and 3)" if only is None else only, args.out)
    left = [n for n in (rundir.ORDER if only is None else (only,)) if rundir.progress(args.out, n) < rundir.total(cfg, n)]
    if left:  # a finished run is told "nothing to train" instead
        check_run_writable(args.out)
        check_machine(cfg, left, args)
    if only is None and not any(rundir.progress(args.out, n) for n in rundir.ORDER):
        raise ValueError(f"{args.out} has no checkpoint yet (the run stopped before its first one); "
                         f"start it again without --resume (the directory is reused)")
    changed = _changed_iterations(args.out, run_cfg, cfg, overrides)
    names = rundir.ORDER if only is None else (only,)
    for name in names:
        d = rundir.stage_dir(args.out, name)
        if name != "ggcnn" and rundir.progress(args.out, name) > 0:
            check_metrics_file(d)
    if only is not None:  # its prerequisites: every earlier stage complete
        for name in rundir.prerequisites(only):
            done, want = rundir.progress(args.out, name), rundir.total(cfg, name)
            if done < want:
                state = "has no checkpoint" if done == 0 else f"reached iteration {done} of {want}"
                raise ValueError(f"{only} starts from the end of {rundir.DESCRIPTION[name]}, and {args.out} "
                                 f"{state} there: run python train.py --out {args.out} --resume (every stage "
                                 f"in order) or --stage {name} first")
    if not (rundir.progress(args.out, "stage1") and rundir.progress(args.out, "stage2")):
        check_net_init(cfg)  # stage 1's GDNet or stage 2's VANet still starts from net.init
    ggcnn_left = only is None and rundir.progress(args.out, "ggcnn") < rundir.total(cfg, "ggcnn")
    data_dir = check_data_dir(args.data_dir) if ggcnn_left else None
    if ggcnn_left:
        check_ggcnn_config(cfg)
    stage1_arrays = None
    done1 = rundir.progress(args.out, "stage1")
    if only is None and 0 < done1 < cfg.stage1.iterations:  # checked now, not after GG-CNN's minutes
        stage1_arrays = read_stage1_checkpoint(args.out, cfg, done1)
    for name in ("stage2", "stage3", "nbv"):  # a stage resumed later: its checkpoint checked now
        done = rundir.progress(args.out, name)
        if only in (None, name) and 0 < done < rundir.total(cfg, name):
            check_vags_checkpoint(args.out, cfg, name, done)
    return SimpleNamespace(cfg=cfg, fresh=False, changed=changed, data_dir=data_dir, stage1_arrays=stage1_arrays)


def prepare_vpg(args) -> SimpleNamespace:
    """--stage vpg: VPG's config (``RUN/vpg/config.json`` when resuming: only vpg.iterations may
    change) and --out (new, or a run without a VPG checkpoint; the run's other files are left
    alone), checked before anything is built.  ``.step``: the checkpoint to resume (0: fresh);
    ``.done``: a message when nothing is left to train."""
    if args.data_dir is not None:
        raise ValueError("--data-dir is for GG-CNN (--stage ggcnn, or the whole pipeline); drop it for --stage vpg")
    if getattr(args, "devices", None) is not None:
        raise ValueError("--devices (data-parallel training) covers stage 1 only so far (--stage gdnet); drop it "
                         "for --stage vpg")
    overrides = C.parse_overrides(args.set)
    _check_out_path(args.out)
    d = vpg_stage.vpg_dir(args.out)
    steps = checkpoint.checkpoint_steps(d) if os.path.isdir(d) else []
    if not args.resume:
        if steps:
            raise ValueError(f"{args.out} already holds a VPG ({d}, checkpoint {steps[-1]}); pass --resume to "
                             f"continue it, or choose another --out")
        if os.path.isdir(args.out):
            _check_only_run_files(args.out)
        cli.check_parent_writable(os.path.join(d, "config.json"), "--out")
        cfg = C.replace(C.preset(args.config or "tiny"), **overrides)
        scene.build_spec(cfg)  # the scene's own checks (shape names), in milliseconds
        vpg_stage.check_config(cfg)
        return SimpleNamespace(cfg=cfg, step=0, done=None)
    if args.config is not None:
        raise ValueError("--resume takes the run's own vpg/config.json; drop --config")
    bad = [k for k in overrides if k != "vpg.iterations"]
    if bad:
        raise ValueError(f"with --resume only vpg.iterations may change (the run's vpg/config.json fixes the "
                         f"rest), got {bad}; start a new run (another --out) to change them")
    if not steps:
        raise ValueError(f"{args.out} has no VPG checkpoint ({d}); start it without --resume")
    cfg = C.replace(checkpoint.load_config(d), **overrides)
    step, total = steps[-1], cfg.vpg.iterations
    if total <= step:
        return SimpleNamespace(cfg=cfg, step=step, done=(
            f"{d} is already at iteration {step}: nothing to train (config.json unchanged); pass --set "
            f"vpg.iterations=N with N > {step} to train further"))
    check_metrics_file(d)
    checkpoint.check_parts(d, step, {"learner": vpg_stage.learner_target(cfg)})  # its network, before any compile
    return SimpleNamespace(cfg=cfg, step=step, done=None)
