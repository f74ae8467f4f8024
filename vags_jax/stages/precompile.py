"""Compile a run's stage programs into the compile cache without training them.

    python -m vags_jax.stages.precompile --run runs/p --stages stage2 --cache-dir DIR
    python -m vags_jax.stages.precompile --config paper --set gate_table.worlds=0 --cache-dir DIR

On a machine with an empty compile cache, the later stages' chunk programs can compile while
stage 1 trains, on the spare CPU cores:

    python train.py --config paper --stage stage1 --out runs/p --cache-dir DIR &
    python -m vags_jax.stages.precompile --run runs/p --stages stage2 --cache-dir DIR   # beside it
    wait; python train.py --out runs/p --resume --cache-dir DIR     # stages 2 and 3: loads it once

For each stage listed, its start runs for real (first scenes and networks: so the device must
have room for a second copy of one stage's worlds beside the training; stage 2's and 3's
replays, the largest arrays, are only shapes) from placeholder networks of the config's shapes,
and its chunk program is lowered and compiled, never run.  A stage started later by
``train.py`` (from a run directory with ``--stage`` or ``--resume``, its inputs restored from
checkpoints, or in the whole pipeline: ``train.py --compile-ahead``) with the same config,
chunk length and cache directory reads that program from the cache instead of compiling it.
Reading it still traces and lowers the program (about 3 minutes for the ``paper`` preset on an
H100), so one ``--resume`` process for stages 2 and 3 pays that once.  Stages 2 and 3 of one
config run one chunk program (``VagsStage.program_key``), so ``stage2`` compiles stage 3's as
well.  Only the first chunk's length is compiled (``--chunk``, else
``pipeline.default_chunk``): a stage whose iterations are not a multiple of it compiles its
last, shorter chunk itself.
"""
from __future__ import annotations

import json
import sys
import time
from typing import Callable, Optional, Sequence

import jax
import jax.numpy as jnp
import numpy as np

from vags_jax import cli
from vags_jax import config as C
from vags_jax.compile_cache import CompileClock
from vags_jax.stages import checkpoint, gate_measure, pipeline, rundir
from vags_jax.stages import ggcnn as ggcnn_stage
from vags_jax.stages.programs import Programs

STAGES = ("stage1", "stage2", "stage3", "gate")  # "gate": the rate gate's table (``stages.gate_measure``)


def placeholder_handover(cfg: C.Config, name: str, has_ggcnn: bool = False) -> pipeline.Handover:
    """What stage ``name`` starts from, as zeros of the shapes a run's checkpoints restore (device
    arrays, as ``checkpoint.restore`` gives them): the previous stages' learners and threshold,
    and GG-CNN's parameters when the run uses one or holds one (``has_ggcnn``)."""
    if name == "stage1":
        return pipeline.Handover()
    dev = lambda tree: jax.tree.map(jnp.asarray, tree)  # noqa: E731
    gg = jax.tree.map(lambda x: jnp.zeros(x.shape, x.dtype), ggcnn_stage.abstract_params()) \
        if rundir.needs_ggcnn(cfg) or has_ggcnn else None
    gd = dev(rundir.learner_target(cfg, "gdnet"))
    if name == "stage2":
        return pipeline.Handover(ggcnn=gg, gdnet=gd)
    return pipeline.Handover(ggcnn=gg, gdnet=gd, vanet=dev(rundir.learner_target(cfg, "vanet")),
                             success=dev(rundir.learner_target(cfg, "gdnet")), threshold=jnp.zeros((), jnp.float32))


def placeholder_networks(cfg: C.Config, has_ggcnn: bool = False) -> rundir.VagsNetworks:
    """Stage 3's networks as ``rundir.load_vags`` gives them, as zeros of their shapes: GDNet,
    VANet, the success net, the "q" threshold, the calibration (3,), GG-CNN's where the run
    uses one or holds one (``has_ggcnn``)."""
    # Host zeros put on the device: no program compiles for them (jnp.zeros would compile one).
    dev = lambda tree: jax.tree.map(lambda x: jax.device_put(np.zeros(x.shape, x.dtype)), tree)  # noqa: E731
    net = lambda kind: dev(rundir.vars_target(cfg, kind))  # noqa: E731
    gg = dev(ggcnn_stage.abstract_params()) if rundir.needs_ggcnn(cfg) or has_ggcnn else None
    return rundir.VagsNetworks(gdnet=net("gdnet"), vanet=net("vanet"), ggcnn=gg,
                               q_threshold=dev(np.zeros((), np.float32)), success=net("gdnet"),
                               calibration=dev(np.zeros((3,), np.float32)), source="stage3 step 0")


def precompile_gate(cfg: C.Config, programs: Optional[Programs] = None, has_ggcnn: bool = False) -> None:
    """The rate gate's table program (``gate_measure.compile_collect``) from placeholder networks."""
    gate_measure.compile_collect(cfg, placeholder_networks(cfg, has_ggcnn), programs)


def precompile(cfg: C.Config, names: Sequence[str], chunk: Optional[int] = None,
               programs: Optional[Programs] = None, log: Callable[[str], None] = print,
               has_ggcnn: bool = False) -> dict:
    """Starts each stage of ``names`` and compiles its chunk program (``chunk`` iterations, else
    ``pipeline.default_chunk`` of the stage's iterations) -> {stage: {"iterations_per_chunk",
    "wall_s", "compile": {"seconds", "compiled", "loaded"}}}.  ``has_ggcnn``: the run holds a
    GG-CNN its stages carry even where they do not use it.  Nothing is trained or written but
    the compile cache."""
    programs = Programs() if programs is None else programs
    report = {}
    for name in names:
        if name == "gate":
            t0 = time.time()
            with CompileClock() as clock:
                precompile_gate(cfg, programs, has_ggcnn)
            report[name] = {"wall_s": round(time.time() - t0, 1), "compile": clock.as_dict()}
            log(f"precompile: the gate table's program ready in {report[name]['wall_s']} s "
                f"({clock.compiled} compiled, {clock.loaded} loaded from the cache)")
            continue
        total = rundir.total(cfg, name)
        n = min(chunk or pipeline.default_chunk(total), total)
        t0 = time.time()
        with CompileClock() as clock:
            stage = programs.stage(name, cfg)
            start = placeholder_handover(cfg, name, has_ggcnn)
            kw = {} if name == "stage1" else {"abstract_replays": True}  # never allocated: they only shape the program
            state = pipeline.stage_fns(name, stage).init(rundir.stage_key(cfg, name), start, **kw)
            stage.compile_chunk(state, n)
        report[name] = {"iterations_per_chunk": n, "wall_s": round(time.time() - t0, 1), "compile": clock.as_dict()}
        log(f"precompile: {name}'s chunk of {n} iterations ready in {report[name]['wall_s']} s "
            f"({clock.compiled} compiled, {clock.loaded} loaded from the cache)")
    return report


def parse_args(argv=None):
    p = cli.ArgumentParser(prog="python -m vags_jax.stages.precompile", description=__doc__,
                           formatter_class=cli.argparse.RawDescriptionHelpFormatter)
    p.add_argument("--run", default=None, help="a run directory: its config.json (as train.py wrote it)")
    p.add_argument("--config", default=None, help="preset, when no --run (default: tiny)")
    p.add_argument("--set", nargs="*", default=[], metavar="SECTION.FIELD=VALUE", help="config overrides")
    p.add_argument("--stages", default="stage2", help="comma-separated, of stage1, stage2, stage3, gate (default: "
                                                      "stage2, whose chunk program stage 3 shares; gate: the rate "
                                                      "gate's table, measured after stage 3)")
    p.add_argument("--chunk", type=cli.int_in(1), default=None,
                   help="iterations per chunk, as train.py --chunk (default: a tenth of each stage, at most 50)")
    p.add_argument("--json", action="store_true", help="print the report as one JSON line at the end")
    cli.add_cache_dir(p)
    args = p.parse_args(argv)
    names = [s for s in args.stages.split(",") if s]
    if not names or set(names) - set(STAGES):
        p.error(f"--stages takes a comma-separated list of {', '.join(STAGES)}, got {args.stages!r}")
    if args.run is not None and (args.config is not None or args.set):
        p.error("--run takes the run's config.json; --config and --set go with a new config only")
    return p, args, names


def main(argv=None) -> int:
    p, args, names = parse_args(argv)
    prog = p.prog
    try:
        if args.run is not None:
            cfg = checkpoint.load_config(args.run)
        else:
            cfg = C.replace(C.preset(args.config or "tiny"), **C.parse_overrides(args.set))
    except ValueError as e:  # CheckpointError included: one line saying what to fix
        return cli.fail(prog, e)
    if cfg.parallel.devices > 1:
        return cli.fail(prog, f"precompile builds one-device programs; this config trains on "
                              f"parallel.devices={cfg.parallel.devices}")
    code = cli.use_compile_cache(prog, args.cache_dir)
    if code is not None:
        return code
    has_ggcnn = args.run is not None and rundir.progress(args.run, "ggcnn") > 0
    report = precompile(cfg, names, args.chunk, log=lambda m: print(m, file=sys.stderr, flush=True),
                        has_ggcnn=has_ggcnn)
    if args.json:
        print(json.dumps(report))
    return 0


if __name__ == "__main__":
    sys.exit(main())
