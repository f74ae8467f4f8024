"""The training pipeline as a fold over stages: GG-CNN, stage 1, stage 2, stage 3.

Each stage is ``make_stage(cfg, name, env) -> StageFns(init, run, output)``:

* ``init(key, handover) -> state``: the stage's carry (``Stage1State``, ``VagsTrainState``) from
  the previous stages' ``Handover`` (stage 1 needs nothing; stage 2 stage 1's GDNet and GG-CNN;
  stage 3 stage 2's GDNet, VANet, success net and threshold, and GG-CNN);
* ``run(state, n) -> (state, metrics of (n,) arrays)``: n iterations, one jitted ``lax.scan``;
* ``output(state, handover) -> handover``: what the stage hands to the next.

``train_in_memory`` is the whole pipeline with nothing written: ``Handover()`` folded through
the stages, each run in chunks of ``default_chunk`` iterations.  ``train.py``
(``vags_jax.stages.driver``) runs the same fold with the same chunks and writes checkpoints and
metrics between chunks as a side effect; only a stage finished by an earlier process (a resume)
takes its input from disk.  Both give the same networks (tests/stages/test_pipeline.py).
"""
from __future__ import annotations

from typing import Any, Callable, NamedTuple, Optional

import jax
import jax.numpy as jnp
from flax import struct

from vags_jax.config import Config
from vags_jax.env import VagsEnv
from vags_jax.rl import dqn
from vags_jax.stages import ggcnn as ggcnn_stage
from vags_jax.stages import rundir
from vags_jax.stages.data_parallel import DataParallelStage1
from vags_jax.stages.stage1 import Stage1
from vags_jax.stages.stage23 import VagsStage, final_threshold


@struct.dataclass
class Handover:
    """What the stages hand on (every field None until a stage sets it): ggcnn: GG-CNN's
    ``{"params"}``; gdnet, vanet, success: ``dqn.TrainState`` learners; threshold: () float32, the
    "q" gate's threshold (stage 3: re-set on its last views, ``final_threshold``)."""

    ggcnn: Any = None
    gdnet: Optional[dqn.TrainState] = None
    vanet: Optional[dqn.TrainState] = None
    success: Optional[dqn.TrainState] = None
    threshold: Optional[jax.Array] = None


class StageFns(NamedTuple):
    """A stage as functions: ``init(key, Handover) -> state``, ``run(state, n) -> (state,
    metrics)``, ``output(state, Handover) -> Handover``; ``program`` is the object holding the
    compiled ``run`` (``Stage1`` / ``VagsStage``)."""

    init: Callable
    run: Callable
    output: Callable
    program: Any


def default_chunk(total: int) -> int:
    """Iterations per jitted chunk when none is asked for: about a tenth of the stage, at most 50."""
    return max(1, min(50, total // 10 or 1))


def stage_fns(name: str, program) -> StageFns:
    """The functions of stage ``name`` ("stage1", "stage2", "stage3") over its built ``program``."""
    if name == "stage1":
        return StageFns(init=lambda key, h: program.init(key), run=program.run,
                        output=lambda s, h: h.replace(gdnet=s.learner), program=program)
    if name == "nbv":  # trained apart (train.py --stage nbv): it hands nothing on
        return StageFns(init=lambda key, h: program.init(key, h.gdnet, h.ggcnn), run=program.run,
                        output=lambda s, h: h, program=program)
    if name == "stage2":
        return StageFns(init=lambda key, h, **kw: program.init(key, h.gdnet, h.ggcnn, **kw), run=program.run,
                        output=lambda s, h: h.replace(gdnet=s.gdnet, vanet=s.vanet, success=s.success,
                                                      threshold=s.threshold), program=program)
    return StageFns(init=lambda key, h, **kw: program.init(key, h.gdnet, h.ggcnn, h.vanet, h.threshold, h.success, **kw),
                    run=program.run,
                    output=lambda s, h: h.replace(gdnet=s.gdnet, vanet=s.vanet, success=s.success,
                                                  threshold=final_threshold(s, program.cfg.vags)),
                    program=program)


def which_stage(name: str):
    """``VagsStage``'s ``which`` of stage ``name`` (stage2 / stage3 / nbv)."""
    return "nbv" if name == "nbv" else int(name[-1])


def make_stage(cfg: Config, name: str, env: VagsEnv) -> StageFns:
    """Stage ``name`` built for ``cfg`` on ``env`` (its programs compile at the first ``run``)."""
    name = rundir.canonical(name)
    if name == "stage1":  # over parallel.devices devices when more than one
        program = DataParallelStage1(cfg, env) if cfg.parallel.devices > 1 else Stage1(cfg, env)
    else:
        program = VagsStage(cfg, which_stage(name), env)
    return stage_fns(name, program)


def run_stage(fns: StageFns, state, total: int, chunk: Optional[int] = None, start: int = 0):
    """``fns.run`` from iteration ``start`` to ``total`` in chunks -> (state, [metrics per chunk])."""
    chunk = chunk or default_chunk(total)
    out, it = [], start
    while it < total:
        n = min(chunk, total - it)
        state, m = fns.run(state, n)
        out.append(m)
        it += n
    return state, out


def train_in_memory(cfg: Config, env: Optional[VagsEnv], ggcnn_data=None, names=rundir.ORDER,
                    handover: Optional[Handover] = None, chunk: Optional[int] = None,
                    build: Optional[Callable] = None):
    """The pipeline as a fold: ``Handover`` through the stages ``names`` -> (Handover, {stage:
    metrics of each chunk}).  ggcnn_data: GG-CNN's ``GGCNNDataset`` (needed when "ggcnn" is
    among ``names``); chunk: iterations per chunk of stages 1-3 (``train.py --chunk``; GG-CNN
    keeps its own, as in ``train.py``'s pipeline); build: ``name -> Stage1 / VagsStage`` to reuse
    programs already built (``driver.Programs.stage``), else each is built on ``env``.
    Nothing is written."""
    h = Handover() if handover is None else handover
    metrics = {}
    for name in names:
        if rundir.total(cfg, name) == 0:  # GG-CNN when the run does not use it
            continue
        if name == "ggcnn":
            params, metrics[name] = ggcnn_stage.train_ggcnn(cfg, ggcnn_data, ggcnn_stage.train_key(cfg))
            h = h.replace(ggcnn=params)
            continue
        fns = make_stage(cfg, name, env) if build is None else stage_fns(name, build(name))
        state = fns.init(rundir.stage_key(cfg, name), h)
        state, metrics[name] = run_stage(fns, state, rundir.total(cfg, name), chunk)
        h = fns.output(state, h)
    return h, metrics


def networks_of(h: Handover) -> dict:
    """The variables of the networks a ``Handover`` holds, as ``rundir.save_networks`` writes them:
    {"gdnet", "vanet", "success": {"params", "batch_stats"}, "threshold"}."""
    as_vars = lambda ts: {"params": ts.params, "batch_stats": ts.batch_stats}  # noqa: E731
    return {"gdnet": as_vars(h.gdnet), "vanet": as_vars(h.vanet), "success": as_vars(h.success),
            "threshold": jnp.asarray(h.threshold, jnp.float32)}


__all__ = ["Handover", "StageFns", "default_chunk", "stage_fns", "make_stage", "run_stage", "train_in_memory",
           "networks_of", "which_stage"]
