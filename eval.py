#!/usr/bin/env python3
"""Benchmark a grasping policy (docs/benchmark.md): groups of k objects, R rounds each.

    python eval.py --run runs/tiny --groups 1,2,3 --rounds 4          # VAGS of a pipeline run
    python eval.py --run runs/s1 --groups 1,2,3 --rounds 4            # GDNet of a stage-1 run, greedy
    python eval.py --run runs/tiny --policy heuristic --groups 1-3    # scripted baseline, same config
    python eval.py --config tiny --policy random --groups 1,2 --rounds 8 --out runs/random.json
    python eval.py --run runs/gpu --set scene.max_objects=10 scene.copies_per_shape=2   # 1..10
    python eval.py --run runs/gpu --objects unseen      # on held-out shapes the networks never saw
    python eval.py --run runs/gpu --policy ggcnn-close  # GG-CNN of train.py --stage ggcnn, close view
    python eval.py --run runs/gpu                       # VAGS (the run's networks and threshold)
    python eval.py --run runs/gpu --no-viewpoint        # VAGS without VANet: GDNet alone
    python eval.py --run runs/gpu --networks stage2 --no-viewpoint   # stage 1's GDNet alone (before stage 3)
    python eval.py --run runs/gpu --threshold-sweep 1.70:1.80:0.01 --quantile-sweep 0:1:0.1 --plot runs/gpu/fig.png
    python eval.py --run runs/gpu --record runs/gpu/pictures --groups 3,10
    python eval.py --run runs/gpu --policy mvp                   # Multi-View Picking (GG-CNN of the run)
    python eval.py --run runs/gpu --policy vpg          # VPG of train.py --stage vpg (pushes and grasps)
    python eval.py --run runs/gpu --compare vags ggcnn mvp nbv --plot runs/gpu/fig7.png   # Table 1

--compare METHOD ...: every method on the same scenes and seed in one environment; prints Table 1
(grasp success and clearing with 95 % Wilson intervals, motion number, picks per hour) and
writes it as JSON + CSV (--out, default RUN/compare[_<objects>].json).

Policies: vags (the default for a run with stage 2 or 3 networks: GDNet, VANet, GG-CNN and
the run's decision threshold, or --threshold), gdnet (the default for a stage-1 run; --step
picks a checkpoint), ggcnn and ggcnn-close (need --run with a GG-CNN from train.py --stage
ggcnn), mvp (Multi-View Picking with the run's GG-CNN), nbv (the next-best-view baseline of
train.py --stage nbv), vpg (needs --run with VPG's nets from train.py --stage vpg: the argmax
over its push and grasp maps; a push is one motion and no grasp attempt), random, highest,
heuristic (see vags_jax/policies/catalog.py).  --no-viewpoint runs VAGS with
its GDNet alone (threshold -inf: the paper's "w/o VANet" ablation).  --threshold-sweep A:B:STEP
evaluates VAGS at each absolute threshold (paper Fig. 6), --quantile-sweep A:B:STEP at the
quantiles of the gate's scores that VAGS saw at its decisions in the main run (GDNet's largest Q
for the paper's "q" gate, minus a move's measured value for "rate"; our Q scale
need not match the paper's); the sweep goes to RUN/eval_vags_sweep.json and .csv.  Groups, rounds, the attempt budget and the robot-time
model of picks per hour come from the config's benchmark section (--set benchmark.rounds=20), and so
does the remedy for piles whose drop spilled an object before the first attempt: dropped again up to 10
times by default (benchmark.redrop_spilled; docs/benchmark.md, "Spilled piles").  The configuration is the run's config.json
(or the --config preset) with --set overrides applied; the scene must hold the largest group
(scene.max_objects).  Prints a Markdown table with a legend of its columns under it
(docs/benchmark.md, "Metrics", defines each) and writes the full report as JSON to --out, or
to RUN/eval_<policy>[_<stage of --networks>][_step<N>].json, with a CSV beside it (one row per group and overall); the
report's process_s says where the process spent its seconds before the first round, and how many
programs it compiled or loaded there.
--plot PATH draws success and clearing against the number of objects (paper Fig. 7), one line per
method (needs matplotlib: pip install 'vags_jax[plot]');
with a sweep, the sweep's plot goes beside it (PATH stem + _sweep.png).  --record DIR writes
pictures of the first --record-rounds rounds of each group (vags only).

Every input (flags, --set values, the run directory and its checkpoint) is checked before
anything is compiled: a bad one ends with one line on stderr and exit code 2.
"""
from __future__ import annotations

import argparse
import os
import sys
import time

_T0 = time.perf_counter()  # before the heavy imports: the process clock of the report's "process_s"

import jax  # noqa: E402
import numpy as np  # noqa: E402

from vags_jax import cli  # noqa: E402
from vags_jax.benchmark import arguments  # noqa: E402
from vags_jax.benchmark import compare as CMP  # noqa: E402
from vags_jax.benchmark import metrics as M  # noqa: E402
from vags_jax.benchmark import protocol as E  # noqa: E402
from vags_jax.benchmark import planners, reports, requests, sweep  # noqa: E402
from vags_jax.benchmark.record_rounds import record_rounds  # noqa: E402
from vags_jax.compile_cache import CompileClock  # noqa: E402
from vags_jax.policies import rate_gate  # noqa: E402

_T_IMPORTED = time.perf_counter()

PROG = "eval.py"


def parse_args(argv=None):
    p = cli.ArgumentParser(prog=PROG, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    arguments.add_eval_arguments(p)
    return p.parse_args(argv)


def main_compare(args) -> int:
    """--compare: every method on the same scenes and seed; Table 1, JSON + CSV, Fig. 7."""
    try:
        plan = requests.prepare_compare(args)  # every method checked, before anything is compiled
    except ValueError as e:
        return cli.fail(PROG, e)
    log = lambda s: print(s, file=sys.stderr, flush=True)  # noqa: E731
    results = CMP.play_methods(plan, lambda mplan: requests.policy_of(mplan, args), log)
    try:
        CMP.publish(results, plan.out, args.plot, {"seed": plan.seed, "groups": plan.groups, "rounds": plan.rounds},
                    log)
    except ValueError as e:  # the methods played other scenes
        print(f"{PROG}: error: {e}", file=sys.stderr)
        return 1
    return 0


def _since(t: float) -> float:
    return round(time.perf_counter() - t, 2)


def _gdnet_note(networks) -> str:
    """", GDNet of stage2 step N" where the run kept the GDNet stage 3 started from (and ", after a
    move stage3 step N" where the grasps after a move use another)."""
    note = f", GDNet of {networks.gdnet_source}" if networks.gdnet_source != networks.source else ""
    close = networks.close_gdnet_source
    return note + (f", after a move {close}" if close and close != networks.gdnet_source else "")


def _startup_seconds(t_main: float, t_inputs: float, t_env: float, new_process: bool, clock: CompileClock) -> dict:
    """Where the process's seconds went before the first round (the report's ``process_s``):
    imports (a new process only), checking the inputs and reading the networks (the device
    starts here), building the environment, building the policy; and ``programs``, the programs
    compiled or loaded from the compile cache in those steps (each costs time in every process)."""
    return {"imports_s": round(_T_IMPORTED - _T0, 2) if new_process else None,
            "inputs_s": round(t_inputs - t_main, 2), "environment_s": round(t_env - t_inputs, 2),
            "policy_s": _since(t_env), "programs": clock.backend}


def main(argv=None) -> int:
    t_main = time.perf_counter()
    args = parse_args(argv)  # bad flags: one line, exit code 2
    cli.quiet_third_party(args.verbose)
    error = cli.use_compile_cache(PROG, args.cache_dir)
    if error is not None:
        return error
    if args.compare:
        return main_compare(args)
    clock = CompileClock().__enter__()  # programs before the first round; _evaluate closes it
    try:
        plan = requests.prepare_eval(args)  # every input, before anything is compiled
    except ValueError as e:  # includes CheckpointError and config validation
        clock.close()
        return cli.fail(PROG, e)
    try:
        return _evaluate(args, plan, t_main, argv, clock)
    except jax.errors.JaxRuntimeError as e:  # XLA's out-of-memory; any other error keeps its traceback
        what = cli.out_of_memory(e)
        if what is None:
            raise
        cli.drop_failed_device_work()
        print(f"{PROG}: error: out of accelerator memory ({what}): play fewer worlds at once (--rounds, --groups), "
              f"lower net.forward_batch (--set net.forward_batch=N), or leave this process more of the device "
              f"(fewer processes beside it, or a larger XLA_PYTHON_CLIENT_MEM_FRACTION); the reports written "
              f"before it stay", file=sys.stderr)
        return 1
    finally:
        clock.close()


def _evaluate(args, plan, t_main: float, argv, clock: CompileClock) -> int:
    """``main`` once every input is checked: plays the plan's seeds, writes the reports, runs the
    sweep, plot and recording it asks for -> exit code.  ``clock``, open since before the inputs,
    is closed once the policy is built."""
    policy, name, cfg, groups, rounds = plan.policy, plan.name, plan.cfg, plan.groups, plan.rounds
    networks, step, out, sweep_out, compare = plan.networks, plan.step, plan.out, plan.sweep_out, plan.compare
    sweep_abs, sweep_q, time_model = plan.sweep_abs, plan.sweep_q, plan.time_model
    log = lambda s: print(s, file=sys.stderr, flush=True)  # noqa: E731
    source = f" ({args.run}, checkpoint {step})" if step is not None else (
        f" ({args.run}, {networks.source}{_gdnet_note(networks)})" if networks is not None else "")
    log(f"evaluating {name}{source}: groups {groups}, {rounds} rounds each, impl={cfg.sim.impl}, "
        f"devices={jax.devices()}")
    if policy == "vags":
        log(planners.describe(cfg, args.no_viewpoint))
        notes = [planners.ablation_note(cfg), planners.pick_note(
            cfg, networks.gate_direct_score if networks is not None and networks.gate_table is not None else None,
            networks.gdnet_source if networks is not None else "")] if args.no_viewpoint else []
        for note in filter(None, notes):
            log(note)
    t_inputs = time.perf_counter()
    try:
        ev = E.Evaluator(cfg)
        t_env = time.perf_counter()
        pol = requests.policy_of(plan, args)
    finally:
        clock.close()
    process = _startup_seconds(t_main, t_inputs, t_env, new_process=argv is None, clock=clock)
    log("ready in " + ", ".join(f"{k[:-2]} {v} s" for k, v in process.items() if k.endswith("_s") and v is not None)
        + f"; {process['programs']} programs compiled or loaded")
    extra = {"run": args.run, "checkpoint_step": step, "process_s": process}
    if policy == "vags":
        extra["planners"] = planners.planners(cfg)
    if policy == "vags" and cfg.vags.gate == "rate" and networks is not None and not args.no_viewpoint:
        table = rate_gate.load_table(args.run, networks.source, networks.gdnet_source,
                                     networks.close_source, cfg.vags.max_motion_number, cfg.vags.cap_split,
                                     cfg.vags.gate_min_z)
        if table is not None:
            extra["rate_gate"] = {**rate_gate.moves_summary(table, cfg.vags.max_motion_number, cfg.vags.gate_min_z),
                                  "estimate": cfg.vags.gate_estimate, "close_score": cfg.vags.close_score,
                                  "direct_score": cfg.vags.direct_score,
                                  "cap_split": cfg.vags.cap_split, "edges": [round(e, 5) for e in table.edges]}
            g = extra["rate_gate"]
            log(f"rate gate: moves in bins {g['moving_bins']} of {g['bins']} (lowest p_direct, the success net's "
                f"{g['estimate']!r} estimate, first; direct grasps planned by {g['direct_score']!r}, grasps after a move "
                f"scored by {g['close_score']!r}); its table "
                f"predicts a motion number of {rate_gate.motion_number_text(g['motion_number'])} and "
                f"{100 * g['success']:.1f} % success"
                + (f" (vags.max_motion_number={g['max_motion_number']:g})" if g["max_motion_number"] else "")
                + (f" (vags.gate_min_z={g['min_z']:g}: no move within that many standard errors of 0)"
                   if g["min_z"] else "")
                + (f"; in bins {g['close_bins']} a move's value is within two standard errors of 0, so the "
                   "table's states could not tell whether it pays there" if g["close_bins"] else ""))
    overall = {}
    for seed in plan.seeds:  # one Evaluator: every seed reuses the programs the first one compiled
        if args.seeds is not None:
            print(f"\nseed {seed}")
        report = E.evaluate(cfg, pol, groups, rounds, seed, time_model, ev, log=log)
        if policy == "vags":
            report["threshold"] = float(np.asarray(pol.params["threshold"]))
            extra["networks"], extra["gdnet"] = networks.source, networks.gdnet_source
            extra["close_gdnet"] = networks.close_source
            log(f"decision threshold {report['threshold']:.4f}")
        print(M.format_table(report))
        branches = M.format_branches(report["overall"])
        if branches:
            log(branches)
        spills = M.format_spills(report["overall"], *report["spilled_remedy"])
        if spills:
            log(spills)
        overall[report["seed"]] = report["overall"]
        path = out if args.seeds is None or not out else requests.seed_path(out, seed)
        if path:
            M.save_report(report, path, cfg, extra)
            reports.write_csv(report, os.path.splitext(path)[0] + ".csv",
                              {"threshold": report["threshold"]} if "threshold" in report else None)
            log(f"wrote {path} and {os.path.splitext(path)[0]}.csv")
    print("\ncolumns:\n" + M.format_legend())
    if args.seeds is not None:
        print(M.format_seeds(name, overall))
    if sweep_abs or sweep_q:
        try:
            rows = sweep.run_sweep(cfg, ev, pol, report, sweep_abs, sweep_q, groups, rounds, args.seed, time_model, log)
        except ValueError as e:  # no decision values to take quantiles of
            print(f"{PROG}: error: {e}", file=sys.stderr)
            return 1
        print(sweep.format_sweep(rows))
        if sweep_out:
            M.save_report({"policy": name, "rows": rows}, sweep_out, cfg, extra)
            reports.write_sweep_csv(rows, os.path.splitext(sweep_out)[0] + ".csv")
            log(f"wrote {sweep_out} and {os.path.splitext(sweep_out)[0]}.csv")
        if args.plot:
            path = os.path.splitext(args.plot)[0] + "_sweep.png"
            reports.plot_sweep(rows, path, title=f"{name}: grasp success vs threshold")
            log(f"wrote {path}")
    if args.plot:
        reports.plot_by_objects({name: report, **compare}, args.plot)
        log(f"wrote {args.plot}")
    if args.record:
        record_rounds(cfg, ev, pol.params, report["seed"], groups, args.record_rounds, rounds, args.record, log)
    log(f"done: {_since(_T0 if argv is None else t_main)} s in this process")
    return 0


if __name__ == "__main__":
    sys.exit(main())
