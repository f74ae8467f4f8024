#!/usr/bin/env python3
"""Train VAGS stage 1 (GDNet) in batched MJX worlds.

    python train.py --config tiny --out runs/tiny          # CPU, a few minutes
    python train.py --config gpu --out runs/gpu            # one H100/H200, impl "warp"
    python train.py --config gpu --set exploration.daes=false --out runs/no_daes
    python train.py --out runs/tiny --resume               # continue exactly where it stopped

Writes into --out: config.json, metrics.jsonl (one line per iteration), checkpoints/ (orbax).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--config", default=None, help="preset: tiny | gpu | paper | default (default: tiny)")
    p.add_argument("--set", nargs="*", default=[], metavar="SECTION.FIELD=VALUE",
                   help="config overrides, e.g. stage1.iterations=200 net.trunk=small")
    p.add_argument("--out", required=True, help="run directory")
    p.add_argument("--resume", action="store_true", help="continue the run in --out from its last checkpoint")
    p.add_argument("--chunk", type=int, default=None,
                   help="iterations per jitted chunk (metrics/progress/checkpoint granularity); default: auto")
    p.add_argument("--checkpoint-every", type=int, default=1, help="checkpoint every N chunks (default 1)")
    p.add_argument("--max-minutes", type=float, default=None,
                   help="stop (with a checkpoint) once this much wall time has passed")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    return p.parse_args(argv)


def resolve_config(args):
    from vags_jax import checkpoint, config as C

    if args.resume:
        cfg = checkpoint.load_config(args.out)
        if args.config is not None:
            raise SystemExit("error: --resume takes the run's own config.json; drop --config")
        overrides = C.parse_overrides(args.set)
        bad = [k for k in overrides if k != "stage1.iterations"]
        if bad:
            raise SystemExit(f"error: with --resume only stage1.iterations may change, got {bad}")
        return C.replace(cfg, **overrides)
    if os.path.isdir(os.path.join(args.out, checkpoint.CHECKPOINT_DIR)):
        raise SystemExit(f"error: {args.out} already holds a run; pass --resume to continue it, "
                         f"or choose another --out")
    cfg = C.preset(args.config or "tiny")
    return C.replace(cfg, **C.parse_overrides(args.set))


def progress_line(it, total, grasps, recent_success, eps, loss, rate, explored):
    width = 24
    done = int(width * it / max(total, 1))
    return (f"\r[{'#' * done}{'.' * (width - done)}] {it}/{total} it | {grasps} grasps | "
            f"success {100 * recent_success:5.1f}% | eps {eps:.3f} | explored {100 * explored:4.1f}% | "
            f"loss {loss:.4f} | {rate:7.1f} grasps/s")


def main(argv=None) -> int:
    args = parse_args(argv)
    try:
        cfg = resolve_config(args)
    except ValueError as e:  # config validation errors carry what to fix
        print(f"error: {e}", file=sys.stderr)
        return 2

    import jax
    import numpy as np

    from vags_jax import checkpoint, stages

    checkpoint.save_config(args.out, cfg)
    stage = stages.make_stage1(cfg)
    state = stage.init(jax.random.PRNGKey(cfg.seed))
    start_it = 0
    if args.resume:
        try:
            state, _ = checkpoint.restore(args.out, state)
        except checkpoint.CheckpointError as e:
            print(f"error: {e}", file=sys.stderr)
            return 2
        start_it = int(state.iteration)
        print(f"resumed {args.out} at iteration {start_it}", file=sys.stderr)

    total = cfg.stage1.iterations
    chunk = args.chunk or max(1, min(50, total // 10 or 1))
    metrics_path = os.path.join(args.out, "metrics.jsonl")
    if not args.resume and os.path.exists(metrics_path):
        os.remove(metrics_path)
    if args.resume and os.path.exists(metrics_path):  # drop lines past the checkpoint
        with open(metrics_path) as f:
            lines = [l for l in f if json.loads(l)["iteration"] < start_it]
        with open(metrics_path, "w") as f:
            f.writelines(lines)

    t0 = time.time()
    it, n_chunks, recent = start_it, 0, []
    grasps_done = int(jax.device_get(state.attempts))
    print(f"training stage 1 (GDNet): {cfg.stage1.n_worlds} worlds, {total} iterations, "
          f"impl={cfg.sim.impl}, trunk={cfg.net.trunk}, daes={cfg.exploration.daes}, "
          f"devices={jax.devices()}", file=sys.stderr)
    while it < total:
        n = min(chunk, total - it)
        tc = time.time()
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
