#!/usr/bin/env python3
"""Train VAGS in batched MJX worlds: GG-CNN (when the run needs it), then stage 1 (GDNet), stage 2
(VANet, GDNet frozen) and stage 3 (both, alternating) -- the whole pipeline with no --stage, or
one stage.

    python train.py --config tiny --out runs/tiny          # the whole pipeline, CPU, minutes
    python train.py --config gpu --out runs/gpu            # one H100/H200, impl "warp"
    python train.py --out runs/gpu --resume                # continue wherever it stopped
    python train.py --config tiny --stage gdnet --out runs/s1      # stage 1 only (GDNet)
    python train.py --config tiny --stage ggcnn --out runs/s1      # GG-CNN only, into a run
    python train.py --out runs/s1 --stage stage2           # stage 2 of an existing run
    python train.py --config gpu --stage gdnet --set exploration.daes=false --out runs/no_daes
    python train.py --config tiny --stage vpg --out runs/tiny      # the VPG baseline, into runs/tiny/vpg

Stages (--stage): ggcnn; stage1 (alias gdnet); stage2 (alias vanet); stage3 (alias alternate); and
two baselines, never part of the whole pipeline: nbv (the NBV baseline of eval.py --policy nbv,
into --out/nbv) and vpg (the VPG baseline: RUN/vpg/ holds its config.json, checkpoints/ and
metrics.jsonl; --resume continues it, and only vpg.iterations may change).
Writes into --out: config.json; stage 1's metrics.jsonl and checkpoints/ (orbax); ggcnn/
(checkpoints/, config.json, metrics.json); stage2/ and stage3/ (checkpoints/, metrics.jsonl);
gate.json (the "rate" gate's table, measured after stage 3: gate_table in the config, worlds=0 skips it);
timings.jsonl (wall-clock of every stage segment); summary.json (the closing summary, printed as
the last stdout line with --json).  Every metrics row names its stage.
The pipeline trains GG-CNN only when the close-view planner uses it (vags.local_planner=ggcnn)
or vags.train_ggcnn is true (for eval.py --policy ggcnn); --stage ggcnn adds one to a run later.
Stage 2 starts from stage 1's final GDNet (and the run's GG-CNN, if it has one); stage 3 from
stage 2's final networks and decision threshold.  GG-CNN's labelled views are cached (--data-dir), so a
pipeline stopped inside GG-CNN's training trains it again from the cached views.

Every input is checked before anything is compiled or written: a bad flag, --set value or run
directory ends with one line on stderr and exit code 2.  Nothing is written to --out until the
inputs are valid, and an --out left by a run that failed before its first checkpoint is reused.
--resume continues from the last checkpoint of the first unfinished stage; only
stage1/2/3.iterations may change, and only for stages that have not been built on (the new
totals are written to config.json).  --max-minutes stops (with a checkpoint) once that much
time has passed, inside or between stages.  A run whose loss or Q values become non-finite
stops with exit code 1, keeping the last good state as its checkpoint.

While it runs it says when each program starts compiling and how long that took, shows a
progress line with an ETA per stage, and ends with a short summary and the next commands.
Ctrl-C or SIGTERM stops at the end of the chunk in flight, with a checkpoint and one line
("interrupted at stage1 iteration N; --resume continues"; exit code 130, 143 for SIGTERM); a
second Ctrl-C abandons the chunk and keeps the last checkpoint.  A world count whose lower bound
of device memory (vags_jax/stages/memory.py) exceeds the device's is refused before compiling.
Compiled programs are cached on disk (--cache-dir, default ~/.cache/vags_jax/compiled): a
resumed or repeated run loads them instead of compiling.  On a GPU the whole pipeline compiles
stage 2's programs in a second process while stage 1 trains (--compile-ahead; its log is
RUN/compile_ahead.log, its time a "compile_ahead" row of timings.jsonl), and the gate table's
program in another while stages 2 and 3 train (RUN/compile_ahead_gate.log).

    python train.py --config gpu --stage gdnet --devices all --out runs/dp   # stage 1 over every local GPU

--devices N (or all) trains stage 1 data-parallel: each device steps n_worlds / N worlds, keeps
its replay shard and samples batch_size / N; gradients and BatchNorm statistics are averaged.
The count is the run's (parallel.devices in config.json): a resume keeps it.  Stages 2 and 3
and the whole pipeline still run on one device.
"""
from __future__ import annotations

import argparse
import sys

from vags_jax import cli
from vags_jax.parallel import mesh as parallel_mesh

PROG = "train.py"
STAGES = ("ggcnn", "stage1", "stage2", "stage3", "gdnet", "vanet", "alternate", "nbv", "vpg")


def parse_args(argv=None):
    p = cli.ArgumentParser(prog=PROG, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--config", default=None, help="preset: tiny | gpu | gpu-edge | paper | default (default: tiny)")
    p.add_argument("--set", nargs="*", default=[], metavar="SECTION.FIELD=VALUE",
                   help="config overrides, e.g. stage1.iterations=200 net.trunk=small")
    p.add_argument("--out", required=True, help="run directory")
    p.add_argument("--stage", choices=STAGES, default=None,
                   help="one stage only: ggcnn (GG-CNN, into --out/ggcnn), stage1 = gdnet (GDNet), "
                        "stage2 = vanet (VANet, GDNet frozen; needs stage 1 in --out, and GG-CNN when "
                        "vags.local_planner=ggcnn), "
                        "stage3 = alternate (both; needs stage 2); nbv (the NBV baseline's viewpoint network, "
                        "trained as VANet but always moving; needs stage 1, and GG-CNN when "
                        "vags.local_planner=ggcnn); vpg (the VPG baseline's push and grasp nets, into "
                        "--out/vpg).  Default: the whole pipeline (without nbv and vpg)")
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
                   help="checkpoint every N chunks (default: by time, see --checkpoint-minutes)")
    p.add_argument("--checkpoint-minutes", type=cli.positive_float(10**6), default=None,
                   help="without --checkpoint-every: checkpoint at the first chunk boundary this many minutes "
                        "after the last checkpoint (default 5); a stage's end, --max-minutes and Ctrl-C always "
                        "checkpoint")
    p.add_argument("--max-minutes", type=cli.positive_float(10**6), default=None,
                   help="stop (with a checkpoint) once this much wall time has passed")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--no-memory-check", action="store_true",
                   help="skip the check that each stage's lower bound of device memory (replay, Q maps, depth "
                        "images: vags_jax/stages/memory.py) fits this device")
    p.add_argument("--json", action="store_true",
                   help="print the JSON summary (also written to RUN/summary.json) as the last stdout line; the "
                        "human summary then goes to stderr")
    p.add_argument("--verbose", action="store_true",
                   help="show third-party logs (Warp kernel loading, absl / orbax INFO), silenced by default")
    p.add_argument("--devices", type=cli.devices, default=None, metavar="N|all",
                   help="stage 1 (--stage gdnet) data-parallel over N local devices, or all of them: worlds, "
                        "replay and batch split evenly (stage1.n_worlds, replay.capacity and dqn.batch_size must "
                        "be multiples of N), gradients averaged; default 1 (a resumed run keeps its own count)")
    p.add_argument("--distributed", action="store_true",
                   help="call jax.distributed.initialize() first (one process per host, from the cluster's "
                        "environment), so that --devices counts every host's devices (untested on several hosts)")
    cli.add_cache_dir(p)
    p.add_argument("--compile-ahead", choices=("auto", "on", "off"), default="auto",
                   help="the whole pipeline: once stage 1's first chunk has run, a second process compiles stage "
                        "2's programs into the compile cache while stage 1 trains, so that stage 2 loads them "
                        "(vags_jax/stages/compile_ahead.py; the device needs room for stage 2's worlds beside "
                        "stage 1's), and once stage 2's first chunk has run another compiles the gate table's "
                        "program.  auto: on a GPU with the compile cache on (default)")
    p.add_argument("--tensorboard", default=None, metavar="DIR",
                   help="also stream every metrics row to TensorBoard event files in DIR (needs the "
                        "tensorboard extra: pip install 'vags_jax[tensorboard]')")
    return p.parse_args(argv)


def main(argv=None, programs=None) -> int:
    """Parse, check, build, run, write (``vags_jax.stages.driver``) -> exit code.  ``programs``:
    a ``driver.Programs`` to reuse programs built by an earlier call in this process."""
    args = parse_args(argv)  # bad flags: one line, exit code 2
    if args.distributed:  # before JAX touches a device
        try:
            parallel_mesh.initialize_distributed()
        except ValueError as e:
            return cli.fail(PROG, e)
    cli.quiet_third_party(args.verbose)
    error = cli.use_compile_cache(PROG, args.cache_dir)
    if error is not None:
        return error
    # Imported once the flags are read: MuJoCo, MJX and the stages take about 4 s to import, so
    # --help and a mistyped flag answer in about a second.
    from vags_jax.stages import driver

    return driver.train(args, programs)


if __name__ == "__main__":
    sys.exit(main())
