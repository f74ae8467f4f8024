"""What ``train.py`` tells a person while it runs and when it ends.

* ``compile_step``: a line when a program's first call starts ("compiling ...") and one with how
  long JAX spent compiling it (``compile_cache.CompileClock``) and running, or that it was
  loaded from the compile cache.
* ``eta``: the time left in a stage, from the seconds per iteration of its chunks after compiling.
* ``closing_lines``: the human summary at the end (per stage: iterations, time, final success,
  where it was written) and the next commands to run.
* ``scalars`` / ``Board``: metrics rows as TensorBoard scalars, written through tensorboardX
  (the optional ``tensorboard`` extra) when ``train.py --tensorboard DIR`` asks for it.
"""
from __future__ import annotations

import contextlib
import importlib.util
import math
import os
import time
from typing import Callable, Iterable, Optional

from vags_jax.compile_cache import CompileClock


TENSORBOARD_EXTRA = "pip install 'vags_jax[tensorboard]'"
# Metrics-row keys that are labels or clocks, not curves.
NOT_SCALARS = ("stage", "iteration", "step", "wall_s")


@contextlib.contextmanager
def compile_step(label: str, log: Optional[Callable[[str], None]]):
    """Around a program's first call: "compiling <label> ..." before it and, after it, how many
    seconds went to compiling and how many to running.  Yields the ``CompileClock``."""
    if log is not None:
        log(f"compiling {label} ...")
    t0 = time.time()
    with CompileClock() as clock:
        yield clock
    if log is not None:
        total = time.time() - t0
        ran = f"(then ran {duration(max(total - clock.seconds, 0.0))})"
        if clock.seconds >= 0.05 and clock.loaded and not clock.compiled:
            log(f"loaded {label} from the compile cache in {duration(clock.seconds)} {ran}")
        elif clock.seconds >= 0.05:
            log(f"compiled {label} in {duration(clock.seconds)} {ran}")
        else:
            log(f"{label}: already compiled in this process ({duration(total)})")


def duration(seconds: float) -> str:
    """``seconds`` for a person: 4.2 s, 3 min 05 s, 2 h 07 min."""
    if not math.isfinite(seconds):
        return "?"
    if seconds < 60:
        return f"{seconds:.1f} s"
    m, s = divmod(int(round(seconds)), 60)
    if m < 60:
        return f"{m} min {s:02d} s"
    h, m = divmod(m, 60)
    return f"{h} h {m:02d} min"


def eta(left: int, run_seconds: float, run_iterations: int) -> Optional[float]:
    """Seconds until ``left`` more iterations are done at the pace of ``run_iterations``
    iterations in ``run_seconds`` (compile time excluded); None before any was timed."""
    if run_iterations <= 0:
        return None
    return left * run_seconds / run_iterations


# ----------------------------------------------------------------------------- the closing summary


def stage_line(s: dict) -> str:
    name = s["stage"]
    if name == "gate":  # the "rate" gate's table (stages.gate_measure)
        what = f"{s['live_states']} states measured, moves in {s['moving_bins']} of {s['bins']} bins of p_direct"
    elif name == "ggcnn":
        ok = s.get("ggcnn_success")
        what = f"{s['steps']} updates, held-out grasp success " + ("-" if ok is None else f"{100 * ok:.1f} %")
    else:
        rate = s.get("recent_success_rate")
        what = (f"{s['iterations']} iterations, {s['grasp_attempts']} grasps, recent success "
                + ("-" if rate is None else f"{100 * rate:.1f} %"))
        if "threshold" in s:
            what += f", threshold {s['threshold']:.4f}"
    return f"  {name:7s} {duration(s['wall_s']):>12s}  {what}  -> {s['out']}"


def next_commands(out: str, progress: dict, finished: bool, data_parallel: bool = False,
                  gate_table: bool = False, quick: bool = False) -> list:
    """What to run next on run ``out``: ``progress`` {stage: "done/total"} of every stage it has;
    ``data_parallel``: stage 1 trained over several devices, which stages 2-3 cannot follow yet;
    ``gate_table``: the run has the "rate" gate's table; ``quick``: the run trained on a CPU, where
    the full benchmark (50 rounds a group; groups 1-3 for the ``tiny`` preset) takes about half an
    hour, so a 12-round look comes first."""
    if not finished:
        return [f"python train.py --out {out} --resume --stage gdnet   # continue where it stopped"
                if data_parallel else f"python train.py --out {out} --resume      # continue where it stopped"]
    counts = {n: [int(x) for x in p.split("/")] for n, p in progress.items()}
    done = {n for n, (have, want) in counts.items() if have > 0 and have >= want}
    cmds = []
    if quick and {"stage1", "stage2", "stage3"} & done:
        cmds.append(f"python eval.py --run {out} --groups 1-3 --rounds 4   # a quick look (the full benchmark "
                    "below took about 30 min for the tiny preset on 2 CPU cores)")
    if {"stage2", "stage3"} & done:
        cmds += [f"python eval.py --run {out}                   # VAGS on the benchmark (docs/benchmark.md)",
                 f"python eval.py --run {out} --no-viewpoint    # the same without VANet (ablation)"]
        if gate_table:
            cmds.append(f"python eval.py --run {out} --set vags.gate=rate   # VAGS with the measured rate gate")
    elif "stage1" in done:
        cmds += [f"python eval.py --run {out}                   # GDNet alone on the benchmark"]
        if not data_parallel:
            cmds.append(f"python train.py --out {out} --stage stage2   # VANet next (then --stage stage3)")
    if "ggcnn" in done:
        cmds.append(f"python eval.py --run {out} --policy ggcnn    # GG-CNN from the global view")
    return cmds


def closing_lines(summaries: Iterable[dict], out: str, progress: dict, wall_s: float, summary_file: str,
                  finished: bool, data_parallel: bool = False, gate_table: bool = False,
                  peak_gib: Optional[float] = None, quick: bool = False) -> list:
    """The human summary: one line per stage trained by this command, the run's progress, where
    the JSON summary is, and the next commands (``next_commands``); ``peak_gib``: the process's
    peak device memory, where the device reports it; ``quick``: as in ``next_commands``."""
    peak = "" if peak_gib is None else f" (peak device memory {peak_gib:.1f} GiB)"
    lines = [f"trained in {duration(wall_s)}: {out}{peak}"]
    lines += [stage_line(s) for s in summaries]
    lines.append("  progress: " + ", ".join(f"{n} {p}" for n, p in progress.items()))
    lines.append(f"  summary (JSON): {summary_file}")
    cmds = next_commands(out, progress, finished, data_parallel, gate_table, quick)
    if cmds:
        lines.append("next:")
        lines += [f"  {c}" for c in cmds]
    return lines


# ----------------------------------------------------------------------------- TensorBoard


def scalars(row: dict) -> dict:
    """One metrics row -> {tag: value}: every finite number but the labels and clocks, tagged
    ``<stage>/<name>`` (``row["stage"]``)."""
    stage = row.get("stage", "train")
    out = {}
    for k, v in row.items():
        if k in NOT_SCALARS or isinstance(v, bool) or not isinstance(v, (int, float)):
            continue
        if math.isfinite(v):
            out[f"{stage}/{k}"] = float(v)
    return out


def check_tensorboard(logdir: Optional[str]) -> None:
    """``--tensorboard DIR``: the extra installed and DIR writable, or ValueError saying what to do."""
    if logdir is None:
        return
    if not logdir:
        raise ValueError("--tensorboard must not be empty; give a log directory")
    if importlib.util.find_spec("tensorboardX") is None:
        raise ValueError(f"--tensorboard needs tensorboardX, which is not installed: {TENSORBOARD_EXTRA}")
    if os.path.exists(logdir) and not os.path.isdir(logdir):
        raise ValueError(f"--tensorboard {logdir!r} is a file, not a directory")


class Board:
    """Metrics rows streamed to TensorBoard event files in ``logdir`` (tensorboardX)."""

    def __init__(self, logdir: str):
        from tensorboardX import SummaryWriter  # the optional extra, checked by check_tensorboard

        self.writer = SummaryWriter(logdir)

    def rows(self, rows: Iterable[dict], step_key: str = "iteration") -> None:
        for row in rows:
            for tag, value in scalars(row).items():
                self.writer.add_scalar(tag, value, int(row[step_key]))
        self.writer.flush()

    def close(self) -> None:
        self.writer.close()


__all__ = ["CompileClock", "compile_step", "duration", "eta", "closing_lines", "next_commands", "scalars",
           "check_tensorboard", "Board"]
