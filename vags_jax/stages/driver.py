"""``train.py``'s work after its checks: the pipeline's fold (``vags_jax.stages.pipeline``) with
logs, checkpoints and timings written between chunks.

A stage runs chunk by chunk (``run_chunks``): after each chunk its metrics rows go to
``metrics.jsonl``, a progress line to stderr and, every ``--checkpoint-every`` chunks, the whole
state to an orbax checkpoint.  The stages hand over in memory (``pipeline.Handover``); a stage
finished by an earlier process (``--resume``, ``--stage``) hands over from its checkpoint.  A
chunk whose loss or Q values are not finite stops the run and keeps the last good state.
``Programs`` holds the built environment and stages of one process, so that a caller running
several commands (a test session) compiles each program once.
"""
from __future__ import annotations

import contextlib
import json
import math
import os
import shutil
import sys
import time
from typing import Callable, Optional

import jax
import jax.numpy as jnp
import numpy as np

from vags_jax import cli
from vags_jax.compile_cache import CompileClock
from vags_jax.ggcnn import data as ggcnn_data
from vags_jax.policies import rate_gate
from vags_jax.stages import (checkpoint, compile_ahead, gate_measure, interrupts, memory, pipeline, progress,
                              requests, run_lock, rundir, stage23)
from vags_jax.stages import ggcnn as ggcnn_stage
from vags_jax.stages import vpg as vpg_stage
from vags_jax.stages.programs import Programs

PROG = "train.py"
SUMMARY_FILE = "summary.json"  # the JSON summary of the last train.py command on a run
# Stage 1's metrics that must stay finite; the run stops (exit code 1) when one is not.
FINITE_METRICS = ("loss", "td_abs", "q_max", "q_executed")


def log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def fail(message) -> int:
    return cli.fail(PROG, message)


# ----------------------------------------------------------------------------- GG-CNN


def train_ggcnn_into(cfg, out: str, data_dir: str, quiet: bool, programs: Programs, chunk=None, stop=None,
                     again: str = "--resume continues", board=None):
    """GG-CNN's data (made or reused from ``data_dir``), training, held-out accuracy and
    checkpoint into ``out``/ggcnn -> (exit code, summary dict or None, params or None).  A stop
    request (``stop``) ends it after the data or a chunk of updates with ``stop.exit_code`` and
    nothing saved (GG-CNN has no checkpoint mid-training; its data stays cached)."""
    t0 = time.time()
    try:
        maker = programs.data_maker(cfg)  # e.g. an unknown shape name in scene.shapes
    except ValueError as e:
        return fail(e), None, None
    d = cfg.ggcnn_data
    log(f"training GG-CNN: {d.views} views ({d.heldout_views} held out) of {d.candidates} grasps, "
        f"{cfg.ggcnn.train_steps} updates of batch {cfg.ggcnn.batch_size}, input {cfg.ggcnn.input_size} px, "
        f"impl={cfg.sim.impl}, device={jax.devices()[0]}")
    try:
        with progress.compile_step("GG-CNN's data (scenes, renders, grasp trials)", log):
            data = ggcnn_data.load_or_make(cfg, maker, data_dir, log)
    except OSError as e:
        return fail(f"cannot write the GG-CNN data cache in {data_dir} ({cli.first_line(e)}); "
                    f"pass another --data-dir"), None, None
    if stop is not None:
        stop.at("ggcnn", None)
    try:
        params, metrics = (None, {"steps": 0}) if stop is not None and stop.requested else ggcnn_stage.train_ggcnn(
            cfg, data, ggcnn_stage.train_key(cfg), log=None if quiet else log, chunk=chunk, stop=stop)
    except FloatingPointError as e:
        print(f"{PROG}: error: {e}. Stopped; nothing was saved", file=sys.stderr)
        return 1, None, None
    if metrics["steps"] < cfg.ggcnn.train_steps:  # stopped by Ctrl-C / SIGTERM
        log(f"interrupted at ggcnn update {metrics['steps']}; nothing of GG-CNN was saved (its labelled views "
            f"stay cached in {data_dir}): {again}")
        return stop.exit_code, None, None
    if board is not None:
        board.rows([{"stage": "ggcnn", **r} for r in metrics["history"]], step_key="step")
    with progress.compile_step("GG-CNN's held-out grasp trials", log):
        acc = ggcnn_stage.heldout_accuracy(cfg, maker.env, params, maker=maker, log=log)
    info = {"steps": metrics["steps"], "training": metrics, "heldout_accuracy": acc,
            "data": dict(data.info), "wall_s": round(time.time() - t0, 1)}
    gdir = ggcnn_stage.save_ggcnn(out, params, info, cfg)
    summary = {"stage": "ggcnn", "steps": metrics["steps"], "train_loss": metrics["train_loss"],
               "heldout_loss": metrics["heldout_loss"], **{k: acc[k] for k in (
                   "ggcnn_success", "label_peak_success", "candidate_success", "views_with_success")},
               "data_reused": data.info["reused"], "data": data.info["path"], "out": gdir,
               "wall_s": info["wall_s"]}
    return 0, summary, params


def _under_lock(out: str, run: Callable[[], int]) -> int:
    """``run()`` while holding the run directory's lock (``run_lock.RunLock``) -> its exit code;
    exit code 2 with one line naming the holder when another live process has it."""
    try:
        lock = run_lock.RunLock(out, log=log).acquire()
    except run_lock.RunLockedError as e:
        return fail(e)
    try:
        return run()
    finally:
        lock.release()


def main_ggcnn(args, programs: Programs, stop, board) -> int:
    """--stage ggcnn: data (made or reused), training, held-out accuracy, checkpoint."""
    try:
        plan = requests.prepare_ggcnn(args)
    except ValueError as e:
        return fail(e)
    return _under_lock(args.out, lambda: _ggcnn_locked(args, plan, programs, stop, board))


def _ggcnn_locked(args, plan, programs: Programs, stop, board) -> int:
    """The rest of ``main_ggcnn`` while the run's lock is held."""
    t0 = time.time()
    code, summary, _ = train_ggcnn_into(plan.cfg, args.out, plan.data_dir, args.quiet, programs, args.chunk, stop,
                                        again="the same command trains it again", board=board)
    if summary is not None:
        report_end(args, summary, [summary], plan.cfg, time.time() - t0, True)
    return code


def run_status(out: str, cfg, only: Optional[str] = None) -> dict:
    """{stage: "done/total"} of every stage the run has or will have (a baseline's, such as
    nbv's, when it is the one asked for or has started)."""
    shown = rundir.ORDER + tuple(n for n in rundir.BASELINES if n == only or rundir.progress(out, n))
    return {n: f"{rundir.progress(out, n)}/{rundir.total(cfg, n)}" for n in shown
            if rundir.total(cfg, n) or rundir.progress(out, n)}


def report_end(args, data: dict, summaries: list, cfg, wall_s: float, finished: bool) -> None:
    """The end of a command: ``data`` (the JSON summary) to RUN/summary.json, and to stdout with
    --json; the human summary and the next commands (``finished``: all this command was asked
    to train is trained) to stdout (stderr with --json).  On a device that reports it, the
    process's peak device memory is added as ``peak_device_gib``."""
    peak = memory.peak_gib()
    if peak is not None:
        data = {**data, "peak_device_gib": peak}
    path = os.path.join(args.out, SUMMARY_FILE)
    with open(path + ".tmp", "w", encoding="utf-8") as f:
        json.dump(data, f, indent=2)
    os.replace(path + ".tmp", path)
    status = run_status(args.out, cfg)
    lines = progress.closing_lines(summaries, args.out, status, wall_s, path, finished, cfg.parallel.devices > 1,
                                   cfg.vags.gate != "rate" and os.path.isfile(os.path.join(args.out, rate_gate.GATE_FILE)),
                                   peak, quick=jax.default_backend() == "cpu")
    print("\n".join(lines), file=sys.stderr if args.json else sys.stdout, flush=True)
    if args.json:
        print(json.dumps(data), flush=True)
def main_vpg(args, programs: Programs, stop, board) -> int:
    """--stage vpg: VPG's push and grasp nets (``stages.vpg``) into --out/vpg, fresh or resumed."""
    try:
        plan = requests.prepare_vpg(args)
    except ValueError as e:
        return fail(e)
    if plan.done:
        print(plan.done, file=sys.stderr)
        return 0
    return _under_lock(args.out, lambda: _vpg_locked(args, plan, programs, stop, board))


def _vpg_locked(args, plan, programs: Programs, stop, board) -> int:
    """The rest of ``main_vpg`` while the run's lock is held: the stage run chunk by chunk
    (``run_chunks``: metrics, checkpoints, the deadline and stop requests as stage 1's)."""
    with CompileClock() as clock:
        return _vpg_segment(args, plan, programs, stop, board, clock)


def _vpg_segment(args, plan, programs: Programs, stop, board, clock) -> int:
    cfg, done, out_dir = plan.cfg, plan.step, vpg_stage.vpg_dir(args.out)
    t0 = time.time()
    recompiles: list = []
    deadline = None if args.max_minutes is None else t0 + 60 * args.max_minutes
    try:
        program = programs.vpg(cfg)
        state = program.init(vpg_stage.stage_key(cfg))
        if done:
            state, _ = checkpoint.restore(out_dir, state, done)
            print(f"resumed {out_dir} at iteration {done}", file=sys.stderr)
    except ValueError as e:  # CheckpointError: a damaged or foreign checkpoint
        return fail(e)
    if not done:  # a VPG directory with no checkpoint (a failed start) is reused: clear what it left
        shutil.rmtree(out_dir, ignore_errors=True)
    os.makedirs(out_dir, exist_ok=True)
    checkpoint.save_config(out_dir, cfg)
    v = cfg.vpg
    log(f"training VPG (push and grasp nets): {v.n_worlds} worlds of {v.min_objects}-{v.max_objects} objects, "
        f"{v.iterations} iterations, impl={cfg.sim.impl}, trunk={cfg.net.trunk}, device={jax.devices()[0]}")
    state, it, status, actions, recent = run_chunks("vpg", program, state, done, v.iterations, out_dir, args,
                                                    deadline, stop=stop, board=board, recompiles=recompiles)
    if end_of_segment(args, "vpg", done, it, t0, status, {**clock.as_dict(), "recompiled_chunks": recompiles}):
        return 1
    if status == "interrupted":
        return stop.exit_code
    data = {"stage": "vpg", "iterations": it, "grasp_attempts": actions, "recent_success_rate": recent,
            "wall_s": round(time.time() - t0, 1), "out": out_dir}
    path = os.path.join(out_dir, SUMMARY_FILE)
    with open(path, "w", encoding="utf-8") as f:
        json.dump(data, f, indent=2)
    lines = [f"trained in {progress.duration(time.time() - t0)}: {out_dir}", progress.stage_line(data),
             f"  progress: vpg {it}/{v.iterations}", f"  summary (JSON): {path}", "next:",
             f"  python eval.py --run {args.out} --policy vpg      # VPG on the benchmark (docs/benchmark.md)"
             if it >= v.iterations else f"  python train.py --stage vpg --out {args.out} --resume"]
    print("\n".join(lines), file=sys.stderr if args.json else sys.stdout, flush=True)
    if args.json:
        print(json.dumps(data), flush=True)
    return 0


# ----------------------------------------------------------------------------- chunks


def nonfinite(metrics: dict, first_iteration: int, names=FINITE_METRICS):
    """A message naming the first iteration whose loss / Q values are not finite, else None.
    ``metrics``: {name: (n,) array} of one chunk starting at ``first_iteration``."""
    for k in range(len(next(iter(metrics.values())))):
        bad = [name for name in names if name in metrics
               and not math.isfinite(float(np.asarray(metrics[name])[k]))]
        if bad:
            return (f"{' and '.join(bad)} became non-finite at iteration {first_iteration + k} "
                    f"({', '.join(f'{n} = {float(np.asarray(metrics[n])[k])}' for n in bad)}): the "
                    f"learning diverged (a resume would repeat it exactly); start a new run with a "
                    f"lower dqn.learning_rate or dqn.optimizer=adam")
    return None


def progress_line(stage, it, total, grasps, recent_success, eps, loss, rate, explored, view_share=None, eta=None):
    """The progress bar's line; ``eta``: seconds left in the stage (None: not yet known)."""
    width = 24
    done = int(width * it / max(total, 1))
    view = "" if view_share is None else f"view {100 * view_share:4.1f}% | "
    left = "ETA ?" if eta is None else f"ETA {progress.duration(eta)}"
    return (f"\r{stage} [{'#' * done}{'.' * (width - done)}] {it}/{total} it | {left} | {grasps} grasps | "
            f"success {100 * recent_success:5.1f}% | {view}eps {eps:.3f} | explored {100 * explored:4.1f}% | "
            f"loss {loss:.4f} | {rate:7.1f} grasps/s\033[K")


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


def _write_rows(path: str, name: str, m: dict, first: int, t0: float) -> list:
    """Appends one chunk's metrics rows to ``path`` -> those rows."""
    rows = []
    with open(path, "a") as f:
        for k in range(len(m["attempts"])):
            row = {"stage": name, **{key: float(np.asarray(v)[k]) for key, v in m.items()}}
            row["iteration"] = first + k
            row["grasp_attempts"] = int(row["attempts_total"])
            row["wall_s"] = round(time.time() - t0, 3)
            f.write(json.dumps(row) + "\n")
            rows.append(row)
    return rows


def run_chunks(name: str, stage, state, start_it: int, total: int, out_dir: str, args, deadline,
               finite=FINITE_METRICS, loss_key: str = "loss", on_save=None, stop=None, board=None,
               recompiles: Optional[list] = None, on_first_chunk: Optional[Callable[[], None]] = None,
               deferred: Optional[list] = None):
    """Advances a stage's state chunk by chunk from ``start_it`` to ``total`` iterations,
    logging every iteration to ``out_dir``/metrics.jsonl (with ``"stage": name``), checkpointing
    into ``out_dir`` (every ``args.checkpoint_every`` chunks, or else at the first chunk boundary
    ``args.checkpoint_minutes`` after the last save; always at the end and when stopping) and
    stopping at ``deadline`` (a time.time() value, or None) or at the first
    chunk boundary after a stop request (``stop``: ``interrupts.StopRequests``).
    Returns (state, iteration reached, status, grasps, recent success): status is "done",
    "out_of_time", "interrupted" or an error message (the learning diverged; the last good state
    is saved).  ``on_save(it, state)`` runs after every checkpoint of a good state; ``board``
    (``progress.Board``) receives every metrics row.  The first chunk says when it compiles and
    how long that took; the progress line's ETA counts the chunks' time without compiling.  A
    later chunk that compiles anything (or loads it from the compile cache) is a recompilation:
    a warning line, and its iteration appended to ``recompiles``.  ``on_first_chunk()`` runs once
    the first chunk has run (its compiling over).  ``deferred``: a list the checkpoint at the
    stage's end is appended to as a ``checkpoint.PendingSave`` still writing (the caller
    finishes it: the next stage starts meanwhile); without it, every save is waited for."""
    metrics_path = os.path.join(out_dir, "metrics.jsonl")
    _trim_metrics(metrics_path, start_it)
    chunk = args.chunk or pipeline.default_chunk(total)
    every = args.checkpoint_every  # None: by time (``checkpoint_minutes``)
    save_s = 60 * (getattr(args, "checkpoint_minutes", None) or CHECKPOINT_MINUTES)
    t0 = last_save = time.time()
    it, n_chunks, recent = start_it, 0, []
    run_s, run_its = 0.0, 0  # time and iterations of the chunks, compiling excluded (the ETA)
    saved_it = start_it if start_it > 0 else None
    if stop is not None:
        stop.at(name, saved_it)
    # A fresh stage has made no attempt; reading its counter would wait for its first scenes.
    grasps_done = 0 if start_it == 0 else int(jax.device_get(state.attempts))
    overflow_named = False  # the first chunk whose physics overflowed its buffers is named once
    guard = contextlib.nullcontext if stop is None else stop.protected  # files are never cut by a 2nd Ctrl-C
    while it < total:
        n = min(chunk, total - it)
        tc = time.time()
        good = state  # the last state whose losses and Q values were finite
        try:
            with progress.compile_step(f"{name}'s chunk of {n} iterations", log if n_chunks == 0 else None) as clock:
                state, m = stage.run(state, n)
                m = jax.device_get(m)
        except jax.errors.JaxRuntimeError as e:
            if cli.out_of_memory(e) is None:
                raise
            cli.drop_failed_device_work()
            if not args.quiet:
                print(file=sys.stderr)
            return good, it, out_of_memory(name, e, saved_it, out_dir), grasps_done, None
        dt = time.time() - tc
        run_s, run_its = run_s + max(dt - clock.seconds, 0.0), run_its + n
        if n_chunks > 0 and clock.backend:
            _warn_recompiled(name, it + n, clock, recompiles, args.quiet)
        with guard():
            rows = _write_rows(metrics_path, name, m, it, t0)
            if board is not None:
                board.rows(rows)
        overflowed = int(np.sum(m.get("buffer_overflow", 0)))
        if overflowed and not overflow_named:
            overflow_named = True
            _warn_overflow(name, it, n, overflowed, args.quiet)
        diverged = nonfinite(m, it, finite)
        if diverged:
            return good, it, _stop_diverged(diverged, stage, good, it, saved_it, out_dir, guard, args.quiet), \
                grasps_done, None
        it += n
        n_chunks += 1
        if n_chunks == 1 and on_first_chunk is not None:
            on_first_chunk()
        grasps_done = int(m["attempts_total"][-1])
        recent = (recent + list(np.asarray(m["success_rate"])))[-max(10, chunk):]
        if not args.quiet:
            print(_chunk_line(name, it, total, grasps_done, recent, m, loss_key, dt - clock.seconds,
                              progress.eta(total - it, run_s, run_its)), end="", file=sys.stderr, flush=True)
        out_of_time = deadline is not None and time.time() > deadline
        stopping = stop is not None and stop.requested
        due = n_chunks % every == 0 if every else time.time() - last_save >= save_s
        if due or it >= total or out_of_time or stopping:
            defer = deferred is not None and it >= total and not (out_of_time or stopping)
            with guard():
                pending = checkpoint.save(out_dir, it, state, wait=not defer)
                if pending is not None:
                    deferred.append(pending)
                saved_it, last_save = it, time.time()
                if stop is not None:
                    stop.at(name, saved_it)
                if on_save is not None:
                    on_save(it, state)
        if (out_of_time or stopping) and it < total:
            if not args.quiet:
                print(file=sys.stderr)
            return state, it, "interrupted" if stopping else "out_of_time", grasps_done, float(np.mean(recent))
    if not args.quiet:
        print(file=sys.stderr)
    return state, it, "done", grasps_done, float(np.mean(recent)) if recent else None


def _stop_diverged(diverged: str, stage, good, it: int, saved_it, out_dir: str, guard, quiet: bool) -> str:
    """``run_chunks``' status when a chunk's metrics are not finite: the last good state (before
    that chunk) is checkpointed at ``it`` unless already saved there or donated away."""
    if saved_it != it and not getattr(stage, "donates", False):  # keep the last good state
        with guard():
            checkpoint.save(out_dir, it, good)
        saved_it = it
    if not quiet:
        print(file=sys.stderr)
    return (f"{diverged}. Stopped; the last good checkpoint is iteration {saved_it} in "
            f"{os.path.join(out_dir, checkpoint.CHECKPOINT_DIR)}")


def _chunk_line(name: str, it: int, total: int, grasps: int, recent: list, m: dict, loss_key: str,
                run_seconds: float, eta) -> str:
    """``progress_line`` after a chunk: m its metrics ((n,) arrays per key), run_seconds its time
    without compiling, recent the latest iterations' success rates."""
    return progress_line(name, it, total, grasps, float(np.mean(recent)), float(m["epsilon"][-1]),
                         float(m[loss_key][-1]), float(np.sum(m["attempts"])) / max(run_seconds, 1e-6),
                         float(np.mean(m["explored"])), float(np.mean(m["view_share"])) if "view_share" in m else None,
                         eta)


def _warn_recompiled(name: str, it: int, clock, recompiles: Optional[list], quiet: bool) -> None:
    if recompiles is not None:
        recompiles.append(it)
    if not quiet:
        print(file=sys.stderr)
    log(f"warning: {name}'s chunk up to iteration {it} compiled {clock.compiled} and loaded {clock.loaded} "
        f"program(s) again ({progress.duration(clock.seconds)}); chunks after the first should reuse the first's")


def _warn_overflow(name: str, it: int, n: int, worlds: int, quiet: bool) -> None:
    """Names the first chunk (iterations it+1..it+n) whose physics overflowed its contact or
    constraint buffers (``worlds``: world-iterations flagged); later ones are in metrics.jsonl."""
    if not quiet:
        print(file=sys.stderr)
    log(f"warning: {name}: contact/constraint buffers overflowed in {worlds} world-iteration(s) of iterations "
        f"{it + 1}-{it + n} (metrics.jsonl: buffer_overflow; later chunks are not named): contacts were dropped "
        "and objects may fall through. Raise sim.contacts_per_world (impl 'jax'; 'warp': naconmax = worlds x "
        "this), sim.naconmax or sim.njmax (impl 'warp')")


def log_timing(out: str, name: str, start_it: int, it: int, wall_s: float, status: str,
               compiles: Optional[dict] = None, **extra) -> None:
    """Appends one stage segment's wall-clock to ``out``/timings.jsonl; ``compiles``: what the
    segment compiled (``CompileClock.as_dict()`` and ``recompiled_chunks``); ``extra``: more fields.
    ``peak_device_gib``: the process's peak device memory so far, where the device reports it."""
    row = {"stage": name, "from": start_it, "to": it, "wall_s": round(wall_s, 1), "status": status,
           "time": time.strftime("%Y-%m-%dT%H:%M:%S"), **extra}
    if compiles is not None:
        row["compile"] = compiles
    peak = memory.peak_gib()
    if peak is not None:
        row["peak_device_gib"] = peak
    with open(os.path.join(out, "timings.jsonl"), "a") as f:
        f.write(json.dumps(row) + "\n")


# Default spacing of checkpoints: a save of the whole state (replay included) costs about as much
# as a stage-1 iteration on an H100 (bench/RESULTS.md, "Compile cache, a 500-round evaluation ...").
CHECKPOINT_MINUTES = 5.0
OUT_OF_MEMORY = "out of accelerator memory"  # how run_chunks' status starts when a chunk ran out of it


def out_of_memory(name: str, e: Exception, saved_it, out_dir: str) -> str:
    """run_chunks' one-line status for a chunk that ran out of accelerator memory: XLA's own
    first line (what it tried to allocate), the settings that lower the need, the checkpoint kept."""
    what = cli.out_of_memory(e) or cli.first_line(e, 160)
    kept = (f"the last checkpoint is iteration {saved_it} in {os.path.join(out_dir, checkpoint.CHECKPOINT_DIR)}"
            if saved_it else "nothing was saved")
    return (f"{OUT_OF_MEMORY} in {name} ({what}): lower {name}.n_worlds, net.forward_batch or camera.render_batch "
            f"(--set on a new run), or use a device with more memory; {kept}")


def end_of_segment(args, name: str, start_it: int, it: int, t0: float, status: str,
                   compiles: Optional[dict] = None) -> bool:
    """Logs a stage segment's wall clock (timings.jsonl) and says how it ended; True when the
    learning diverged or ran out of memory (``status`` is then the message)."""
    ok = status in ("done", "out_of_time", "interrupted")
    failed = "out_of_memory" if status.startswith(OUT_OF_MEMORY) else "diverged"
    log_timing(args.out, name, start_it, it, time.time() - t0, status if ok else failed, compiles)
    if not ok:
        print(f"{PROG}: error: {status}", file=sys.stderr)
    elif status == "out_of_time":
        print(f"stopped after {args.max_minutes} min at {name} iteration {it}; --resume continues", file=sys.stderr)
    elif status == "interrupted":
        print(f"interrupted at {name} iteration {it}; --resume continues", file=sys.stderr)
    return not ok


# ----------------------------------------------------------------------------- stages 1-3


def handover_from_disk(run_dir: str, cfg, name: str, h: pipeline.Handover) -> pipeline.Handover:
    """``h`` with what stage ``name`` needs from stages finished by an earlier process, read
    from their checkpoints (fields already set, in memory, are kept)."""
    if h.ggcnn is None and name in ("stage2", "stage3", "nbv"):
        h = h.replace(ggcnn=rundir.ggcnn_params(run_dir, cfg, name))
    if name in ("stage2", "nbv") and h.gdnet is None:
        h = h.replace(gdnet=rundir.stage1_gdnet(run_dir, cfg, name))
    if name == "stage3" and h.vanet is None:
        gd, va, su, thr = rundir.stage2_result(run_dir, cfg, name)
        h = h.replace(gdnet=gd, vanet=va, success=su, threshold=thr)
    return h


def _restore_target(fns: pipeline.StageFns, cfg, name: str, gg):
    """A state of the right structure for stage ``name``'s checkpoint (placeholder learners)."""
    key = rundir.stage_key(cfg, name)
    if name == "stage1":
        return fns.init(key, pipeline.Handover())
    gd, va = rundir.learner_target(cfg, "gdnet"), rundir.learner_target(cfg, "nbv" if name == "nbv" else "vanet")
    return fns.init(key, pipeline.Handover(ggcnn=gg, gdnet=gd, vanet=va, success=gd, threshold=0.0))


def run_stage(cfg, args, name: str, done: int, h: pipeline.Handover, deadline, programs: Programs, arrays=None,
              stop=None, board=None, on_first_chunk=None, deferred=None):
    """Stage ``name`` from its start (``h``, the previous stages' output) or from its checkpoint
    ``done`` (``arrays``: stage 1's, read and checked by ``requests``), trained to its
    iterations or to a stop request (``stop``) -> (summary dict, Handover after it), or (exit
    code, None).  A second Ctrl-C (KeyboardInterrupt) is logged in timings.jsonl and re-raised.
    ``on_first_chunk()``: run once the stage's first chunk has run; ``deferred``: collects the
    stage's last checkpoint, still being written (both ``run_chunks``)."""
    with CompileClock() as clock:
        return _run_stage(cfg, args, name, done, h, deadline, programs, arrays, stop, board, clock, on_first_chunk,
                          deferred)


def _run_stage(cfg, args, name, done, h, deadline, programs, arrays, stop, board, clock, on_first_chunk=None,
               deferred=None):
    t0 = time.time()
    recompiles: list = []
    compiles = lambda: {**clock.as_dict(), "recompiled_chunks": recompiles}  # noqa: E731
    out_dir = rundir.stage_dir(args.out, name)
    st = getattr(cfg, name)
    try:
        fns = pipeline.stage_fns(name, programs.stage(name, cfg))
        if done == 0:
            with progress.compile_step(f"{name}'s start (first scenes and networks)", log):
                state = fns.init(rundir.stage_key(cfg, name), handover_from_disk(args.out, cfg, name, h))
        elif name == "stage1":
            state = checkpoint.fit(args.out, done, _restore_target(fns, cfg, name, None), arrays)
        else:
            gg = h.ggcnn if h.ggcnn is not None else rundir.ggcnn_params(args.out, cfg, name)
            state, _ = checkpoint.restore(out_dir, _restore_target(fns, cfg, name, gg), done)
    except ValueError as e:  # config validation, CheckpointError: damaged or foreign checkpoint
        return fail(e), None
    if done:
        print(f"resumed {out_dir if name != 'stage1' else args.out} at iteration {done}", file=sys.stderr)
    os.makedirs(out_dir, exist_ok=True)
    checkpoint.save_config(args.out, cfg)
    if name == "stage1":
        finite, loss_key, on_save = FINITE_METRICS, "loss", None
        d = cfg.parallel.devices
        k = st.n_worlds // d
        where = (f"data parallel over {d} devices ({k} world{'s' if k > 1 else ''} each): "
                 f"{jax.devices()[:d]}" if d > 1 else f"device={jax.devices()[0]}")
        log(f"training stage 1 (GDNet): {st.n_worlds} worlds, {st.iterations} iterations, impl={cfg.sim.impl}, "
            f"trunk={cfg.net.trunk}, daes={cfg.exploration.daes}, {where}")
    else:
        finite, loss_key = stage23.FINITE_METRICS, "loss_vanet"
        on_save = lambda i, s: rundir.save_networks(args.out, name, i, s, cfg)  # noqa: E731
        log(f"training {rundir.DESCRIPTION[name]}: {st.n_worlds} worlds of {st.min_objects}-{st.max_objects} "
            f"objects, {st.iterations} iterations, decision threshold {float(state.threshold):.4f}, "
            f"device={jax.devices()[0]}")
    try:
        state, it, status, grasps, recent = run_chunks(name, fns.program, state, done, st.iterations, out_dir,
                                                       args, deadline, finite, loss_key, on_save, stop, board,
                                                       recompiles, on_first_chunk, deferred)
    except KeyboardInterrupt:
        log_timing(args.out, name, done, stop.saved if stop and stop.saved else done, time.time() - t0, "abandoned",
                   compiles())
        raise
    if end_of_segment(args, name, done, it, t0, status, compiles()):
        return 1, None
    summary = {"stage": name, "iterations": it, "grasp_attempts": grasps, "recent_success_rate": recent}
    if cfg.parallel.devices > 1 and name == "stage1":
        summary["devices"] = cfg.parallel.devices
    if name not in ("stage1", "nbv"):  # NBV's is +inf: it always moves
        summary["threshold"] = float(state.threshold)
    summary.update(wall_s=round(time.time() - t0, 1), out=out_dir)
    h = fns.output(state, h) if it >= st.iterations else h
    if deferred:  # the last checkpoint still reads this state's arrays: the next stage donates copies
        h = jax.tree.map(lambda x: jnp.array(x, copy=True) if isinstance(x, jax.Array) else x, h)
    return summary, h


def main_stage1(args, programs: Programs, stop, board) -> int:
    """--stage gdnet (stage1): stage 1 only, fresh or resumed."""
    try:
        plan = requests.prepare_stage1(args)
    except ValueError as e:  # config validation / CheckpointError: what to fix
        return fail(e)
    if plan.done:
        print(plan.done, file=sys.stderr)
        return 0
    return _under_lock(args.out, lambda: _stage1_locked(args, plan, programs, stop, board))


def _stage1_locked(args, plan, programs: Programs, stop, board) -> int:
    """The rest of ``main_stage1`` while the run's lock is held."""
    if not args.resume:  # a run directory with no checkpoint (a failed start) is reused: clear what it left
        leftover = os.path.join(args.out, checkpoint.CHECKPOINT_DIR)
        if os.path.isdir(leftover):
            shutil.rmtree(leftover)
    if plan.raised_from is not None:
        print(f"stage1.iterations {plan.raised_from} -> {plan.cfg.stage1.iterations} (written to "
              f"{os.path.join(args.out, checkpoint.CONFIG_FILE)})", file=sys.stderr)
    t0 = time.time()
    deadline = None if args.max_minutes is None else t0 + 60 * args.max_minutes
    summary, _ = run_stage(plan.cfg, args, "stage1", plan.step, pipeline.Handover(), deadline, programs,
                           plan.arrays, stop, board)
    if isinstance(summary, int):
        return summary
    if stop.requested and summary["iterations"] < plan.cfg.stage1.iterations:
        return stop.exit_code
    report_end(args, summary, [summary], plan.cfg, time.time() - t0,
               summary["iterations"] >= plan.cfg.stage1.iterations)
    return 0


def _clear_failed_start(out: str) -> None:
    """A run directory with no checkpoint (a failed start) is reused: clear what it left."""
    for name in ("checkpoints", "stage2", "stage3", "timings.jsonl", "metrics.jsonl", SUMMARY_FILE):
        path = os.path.join(out, name)
        if os.path.isdir(path):
            shutil.rmtree(path)
        elif os.path.exists(path):
            os.remove(path)


def main_pipeline(args, only, programs: Programs, stop, board) -> int:
    """The whole pipeline (only None: GG-CNN, stages 1, 2, 3, each from where it stopped), or
    stage 2 / 3 alone: the fold of ``vags_jax.stages.pipeline`` with its side effects."""
    try:
        plan = requests.prepare_pipeline(args, only)
    except ValueError as e:
        return fail(e)
    names = rundir.ORDER if only is None else (only,)
    if (not plan.fresh and all(rundir.progress(args.out, n) >= rundir.total(plan.cfg, n) for n in names)
            and not (only in (None, "stage3") and gate_measure.due(args.out, plan.cfg))):
        status = run_status(args.out, plan.cfg, only)
        log(f"{args.out} is already trained ({', '.join(f'{n} {p}' for n, p in status.items())}): nothing to "
            f"train; evaluate it with python eval.py --run {args.out}, or raise STAGE.iterations with --resume "
            f"--set to train further")
        return 0
    return _under_lock(args.out, lambda: _pipeline_locked(args, only, plan, programs, stop, board))


def _pipeline_locked(args, only, plan, programs: Programs, stop, board) -> int:
    """The rest of ``main_pipeline`` while the run's lock is held."""
    cfg = plan.cfg
    if plan.fresh:
        _clear_failed_start(args.out)
    checkpoint.save_config(args.out, cfg)
    for key, (old, new) in plan.changed.items():
        print(f"{key} {old} -> {new} (written to {os.path.join(args.out, checkpoint.CONFIG_FILE)})", file=sys.stderr)
    t0 = time.time()
    deadline = None if args.max_minutes is None else t0 + 60 * args.max_minutes
    summaries, h = [], pipeline.Handover()
    names = rundir.ORDER if only is None else (only,)
    ahead = _compile_ahead(args, cfg, only)
    gate_ahead = _compile_gate_ahead(args, cfg, only)
    deferred: list = []  # stages' last checkpoints, written while the next stage starts
    try:
        return _pipeline_stages(args, only, plan, programs, stop, board, cfg, t0, deadline, summaries, h, names, ahead,
                                deferred, gate_ahead)
    finally:
        for child in (ahead, gate_ahead):
            if child is not None:
                child.close()
        with stop.protected():  # a second Ctrl-C must not cut a checkpoint's files
            _finish_saves(deferred)


def _finish_saves(deferred: list) -> None:
    """Waits until every deferred checkpoint is on disk."""
    while deferred:
        deferred.pop(0).finish()


def _finish_ahead(args, child: compile_ahead.CompileAhead, row: str, part: str) -> None:
    """Waits for a compile-ahead child and logs it in timings.jsonl as ``row`` (``part``: the
    key of its report whose compile counts the row keeps)."""
    got = child.finish()
    extra = {k: got[k] for k in ("last_line", "out_of_memory") if k in got}  # a failed child's error
    log_timing(args.out, row, 0, 1 if got["status"] == "done" else 0, got.get("wall_s", 0.0), got["status"],
               (got.get("report") or {}).get(part, {}).get("compile"), waited_s=got.get("waited_s", 0.0), **extra)


def _compile_ahead(args, cfg, only) -> Optional[compile_ahead.CompileAhead]:
    """The second process that compiles stage 2's programs while stage 1 trains
    (``stages.compile_ahead``), when ``--compile-ahead`` and this run call for one: the whole
    pipeline, stage 1 still to train here and stage 2 not begun.  Says why not, unless off."""
    mode = getattr(args, "compile_ahead", "off")
    if (only is not None or mode == "off" or cfg.parallel.devices > 1 or not cfg.stage2.iterations
            or rundir.progress(args.out, "stage1") >= rundir.total(cfg, "stage1")
            or rundir.progress(args.out, "stage2") > 0):
        return None
    why = compile_ahead.why_not(mode, args.cache_dir, jax.default_backend())
    if why is not None:
        if mode == "on":
            log(f"compile ahead: not started: {why}")
        return None
    argv = compile_ahead.command(args.out, compile_ahead.cache_root(args.cache_dir), args.chunk)
    return compile_ahead.CompileAhead(args.out, argv, log=log)


def _compile_gate_ahead(args, cfg, only) -> Optional[compile_ahead.CompileAhead]:
    """The second process that compiles the rate gate's table program while stage 2 or 3 trains,
    when ``--compile-ahead`` and this run call for one: the whole pipeline measures the table
    (``gate_table.worlds`` > 0) and stage 3 is still to train here.  Says nothing when not."""
    mode = getattr(args, "compile_ahead", "off")
    if (only is not None or mode == "off" or cfg.parallel.devices > 1 or cfg.gate_table.worlds == 0
            or not cfg.stage3.iterations or rundir.progress(args.out, "stage3") >= rundir.total(cfg, "stage3")
            or compile_ahead.why_not(mode, args.cache_dir, jax.default_backend()) is not None):
        return None
    argv = compile_ahead.command(args.out, compile_ahead.cache_root(args.cache_dir), None, stages="gate")
    return compile_ahead.CompileAhead(args.out, argv, log=log, what="the gate table's program",
                                      during="stages 2 and 3 train", log_file=compile_ahead.GATE_LOG_FILE)


def _pipeline_stages(args, only, plan, programs, stop, board, cfg, t0, deadline, summaries, h, names, ahead,
                     deferred, gate_ahead=None) -> int:
    """The stages of ``_pipeline_locked`` in order, then the gate's table and the closing summary;
    ``ahead`` / ``gate_ahead``: the children compiling stage 2's and the gate's programs, started
    after stage 1's and after stage 2's (or 3's) first chunk."""
    for name in names:
        done, want = rundir.progress(args.out, name), rundir.total(cfg, name)
        if done >= want:
            continue
        if deadline is not None and time.time() > deadline:
            print(f"stopped after {args.max_minutes} min before {name}; --resume continues", file=sys.stderr)
            break
        if stop.requested:
            print(f"interrupted at {name} iteration {done}; --resume continues", file=sys.stderr)
            return stop.exit_code
        if name == "ggcnn":
            ts = time.time()
            code, summary, params = train_ggcnn_into(cfg, args.out, plan.data_dir, args.quiet, programs, stop=stop,
                                                     board=board)
            log_timing(args.out, "ggcnn", 0, 1 if code == 0 else 0, time.time() - ts,
                       "done" if code == 0 else "interrupted" if stop.requested else "error")
            if code:
                return code
            h = h.replace(ggcnn=params)
        else:
            try:
                programs.env(cfg)
            except ValueError as e:
                return fail(e)
            arrays, plan.stage1_arrays = (plan.stage1_arrays, None) if name == "stage1" else (None, plan.stage1_arrays)
            if name == "stage2" and ahead is not None:
                _finish_ahead(args, ahead, "compile_ahead", "stage2")
            first = ahead.start if name == "stage1" and ahead is not None else (
                gate_ahead.start if name in ("stage2", "stage3") and gate_ahead is not None else None)
            summary, h = run_stage(cfg, args, name, done, h, deadline, programs, arrays, stop, board, first, deferred)
            if isinstance(summary, int):
                return summary
            if stop.requested and summary["iterations"] < want:
                return stop.exit_code
        summaries.append(summary)
        if summary.get("iterations", want) < want:  # stopped by --max-minutes
            break
    # Stage 3's last checkpoint may still be writing (``deferred``): whether it finished is known here.
    stage3_finished = any(x.get("stage") == "stage3" and x.get("iterations", 0) >= rundir.total(cfg, "stage3")
                          for x in summaries) or None
    if only in (None, "stage3") and gate_measure.due(args.out, cfg, stage3_finished):
        if deadline is not None and time.time() > deadline:
            print(f"stopped after {args.max_minutes} min before the rate gate's table; --resume measures it",
                  file=sys.stderr)
        else:
            if gate_ahead is not None:
                _finish_ahead(args, gate_ahead, "compile_ahead_gate", "gate")
            summaries.append(measure_gate(args, cfg, programs))
    with stop.protected():
        _finish_saves(deferred)  # the summary reads each stage's progress from its checkpoints
    report_end(args, {"stages": summaries, "progress": run_status(args.out, cfg, only),
                      "wall_s": round(time.time() - t0, 1), "out": args.out}, summaries, cfg, time.time() - t0,
               all(rundir.progress(args.out, n) >= rundir.total(cfg, n) for n in names))
    return 0


def measure_gate(args, cfg, programs: Programs) -> dict:
    """The "rate" gate's table of the trained run (``stages.gate_measure``) into RUN/gate.json,
    after stage 3 -> its closing-summary entry."""
    ts = time.time()
    log(f"rate gate: measuring its table ({cfg.gate_table.worlds} piles x {cfg.gate_table.steps} attempts, "
        f"both branches from every state; its programs compile first) ...")
    with CompileClock() as clock:
        path, table, meta = gate_measure.measure_into(args.out, log=(lambda m: None) if args.quiet else log,
                                                      programs=programs)
    wall = time.time() - ts
    log(f"rate gate: table measured in {progress.duration(wall)} ({progress.duration(clock.seconds)} of it "
        f"compiling) -> {path}")
    log_timing(args.out, "gate", 0, 1, wall, "done", clock.as_dict())
    return {"stage": "gate", "wall_s": round(wall, 1), "gdnet": meta["gdnet"],
            "close_gdnet": meta["close_gdnet"], "live_states": meta["live_states"],
            "bins": len(table.states),
            "moving_bins": sum(v > 0 for v in table.move_value), "rate": table.rate, "out": path}


def train(args, programs: Optional[Programs] = None) -> int:
    """Runs what the parsed ``train.py`` command line asks for -> exit code.  Ctrl-C / SIGTERM
    stop it at the next chunk boundary with a checkpoint (exit code 130 / 143); a second
    Ctrl-C abandons the chunk in flight, keeping the last checkpoint: one line either way."""
    programs = Programs() if programs is None else programs
    stage = rundir.canonical(args.stage) if args.stage not in (None, "vpg") else None  # vpg: its own command
    if stage == "stage1" and args.data_dir is not None:
        return fail("--data-dir is for GG-CNN (--stage ggcnn, or the whole pipeline); drop it for --stage gdnet")
    try:
        progress.check_tensorboard(args.tensorboard)
    except ValueError as e:
        return fail(e)
    board = progress.Board(args.tensorboard) if args.tensorboard else None
    with interrupts.StopRequests() as stop:
        try:
            if stage == "ggcnn":
                return main_ggcnn(args, programs, stop, board)
            if stage == "stage1":
                return main_stage1(args, programs, stop, board)
            if args.stage == "vpg":  # VPG, the baseline: not a stage of the VAGS pipeline
                return main_vpg(args, programs, stop, board)
            return main_pipeline(args, stage, programs, stop, board)
        except KeyboardInterrupt:  # a second Ctrl-C: the chunk in flight is lost, the last checkpoint kept
            print(file=sys.stderr)
            print(stop.abandoned_line(), file=sys.stderr)
            return stop.exit_code
        finally:
            if board is not None:
                board.close()


__all__ = ["Programs", "train", "main_vpg", "run_chunks", "run_stage", "nonfinite", "handover_from_disk", "FINITE_METRICS"]
