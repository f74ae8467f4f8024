#!/usr/bin/env python3
"""Training throughput: grasp attempts/s while training (collect + learn), where one stage-1
iteration's time goes, and the DQN update's model FLOP utilisation in bf16.

    python bench/train_throughput.py --config gpu --out runs/throughput.json
    python bench/train_throughput.py --config gpu --set stage1.n_worlds=1024 stage1.updates_per_iteration=32
    python bench/train_throughput.py --config tiny --iterations 4 --trunks small     # CPU smoke run
    python bench/train_throughput.py --run runs/vags --stage stage3 --trunks small   # stage 3, from a trained run

1. Whole iterations: ``Stage1.run`` (one jitted scan, as train.py runs it) on a replay already
   holding ``learning_starts`` transitions; attempts/s = grasp attempts / wall clock.
2. Phases of one iteration, each jitted alone on the same arrays and timed on its own:
   GDNet's forward pass over every rotation + DAES's choice (``Stage1.act``: with
   ``net.forward_needed_only`` on the worlds that do not explore, at the state's epsilon); the grasp physics (no render);
   rendering + heightmaps of every world; adding to replay; replay sampling (x updates per
   iteration); the DQN updates on a fixed batch (x updates per iteration).  "rest of the
   iteration" is the whole iteration minus their sum (what fusion hides shows up negative).
   "metrics to host per iteration" is a chunk's metrics copy to the host (train.py's work
   between chunks) spread over the default chunk's iterations.  One checkpoint save of the
   whole state is timed apart (``checkpoint_save_s``): train.py saves by time (every
   ``CHECKPOINT_MINUTES``, and at a stage's end), not per chunk.
3. Update MFU: the model FLOPs of one DQN update (``flop_count``; XLA's ``cost_analysis`` is
   printed beside it; on an H100 it counted 1-3 % of the model FLOPs) x updates/s, against the peak
   of a large bf16 matrix multiply measured in this script on this device, for each trunk of
   ``--trunks`` (DenseNet-121 at the config's heightmap size and rotations); and the update's
   parts: the target pass (its rotated inputs, trunks + head, maps back to the heightmap) and the
   online network's forward + backward pass, each jitted alone.
``--stage stage2`` / ``stage3`` (with ``--run``) replaces 1 and 2 by that stage's attempts/s over
whole iterations, from the run's saved networks (``vags_stage_iterations``), and its phases:
VANet's pass and the gate, the attempt's plan (close views, fused maps, the close-view planner),
physics, rendering + heightmaps, GDNet's pass over the new views, and the updates of its three
networks (``vags_stage_phases``); then measures 3.
``--updates-only`` measures 3 alone: no environment is built, so it needs neither MuJoCo nor the
physics' compile time (for DenseNet-121 on a machine whose time is short).
Writes every figure to --out as JSON.  Timings mean something on a GPU only (bench/RESULTS.md).

    python bench/train_throughput.py --config gpu --updates-only --out runs/mfu.json
    python bench/train_throughput.py --config gpu --updates-only --no-parts --trunks densenet121   # one compile
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from typing import Optional

import jax
import jax.numpy as jnp
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from compile_time import random_transitions  # noqa: E402
from flop_count import forward_flops  # noqa: E402
from timing import matmul_peak  # noqa: E402

from vags_jax import compile_cache  # noqa: E402
from vags_jax import config as C  # noqa: E402
from vags_jax.nets import (coarse_to_heightmap, initial_variables, make_qnet, pad_inputs, padded_size,  # noqa: E402
                           rotated_inputs, rotation_angles, trunk_geometry)
from vags_jax.rl import dqn, exploration, replay  # noqa: E402


def timed(fn, *args, reps: int = 5) -> float:
    """Mean seconds of ``fn(*args)`` over ``reps`` calls after one warm-up (compile) call."""
    jax.block_until_ready(fn(*args))
    t = time.perf_counter()
    for _ in range(reps):
        out = fn(*args)
    jax.block_until_ready(out)
    return (time.perf_counter() - t) / reps


def flops_of(jitted, *args) -> float:
    cost = jitted.lower(*args).compile().cost_analysis()
    cost = cost[0] if isinstance(cost, (list, tuple)) else cost
    return float(cost.get("flops", float("nan")))


def random_batch(cfg, key, b: int):
    """A replay sample of ``b`` random transitions of this config's heightmap size (in stage 1's
    replay type: with ``stage1.bootstrap = "actor"`` values instead of next states, with
    ``"actor_argmax"`` next actions beside them)."""
    t, _ = random_transitions(cfg, key, b)
    if cfg.stage1.bootstrap == "actor":
        t = replay.make_valued_transition(t.color, t.height, t.action, t.reward, t.done).replace(
            next_value=jax.random.uniform(key, (b,)))
    elif cfg.stage1.bootstrap == "actor_argmax":  # random actions stand in for the actor's argmax
        t = replay.make_argmax_transition(t.color, t.height, t.action, t.reward, t.next_color, t.next_height,
                                          t.done).replace(next_action=jnp.roll(t.action, 1, axis=0))
    buffer = replay.add(replay.init(b, jax.tree.map(lambda x: x[0], t)), t)
    _, batch, w = replay.sample(buffer, key, cfg.dqn.batch_size, cfg.replay.alpha, cfg.replay.beta)
    return batch, w


def update_mfu(cfg, peak: float, n_updates: int, reps: int = 3, parts: bool = True) -> dict:
    """One DQN update of GDNet (this config's trunk): model FLOPs, updates/s, MFU against ``peak``
    and where the update's time goes (each part jitted alone on the same arrays).

    Model FLOPs (``flop_count``): the target network's pass over every rotation of the next
    states (twice with ``double_q``; none with gamma 0 or ``stage1.bootstrap = "actor"``; one
    rotation's share with ``"actor_argmax"``) plus 3 x the online network's forward
    pass at the executed rotations (train mode).  XLA's own count is kept beside it
    (``xla_flops``): on an H100 it counted 1-3 % of the model FLOPs (bench/RESULTS.md).
    ``parts=False`` skips the parts and XLA's count, each a compile of its own (DenseNet-121's
    measurement with them did not finish in 400 s on a bare H200); ``xla_flops`` is then None
    and ``parts`` empty."""
    net = make_qnet(cfg.net, "gdnet")
    H = cfg.workspace.heightmap_px
    apply = lambda v, c, h, train, mutable=False, rotations=None: net.apply(  # noqa: E731
        v, c, h, train, rotations=rotations, mutable=mutable)
    variables = initial_variables(jax.random.PRNGKey(0), net, cfg.net, H, H)
    learner = dqn.create_train_state(variables, cfg.dqn)
    update = dqn.make_update_step(apply, cfg.dqn, executed_rotation_only=True, n_rotations=cfg.net.n_rotations)
    batch, w = random_batch(cfg, jax.random.PRNGKey(1), max(cfg.dqn.batch_size, 8))
    many = jax.jit(lambda ts: jax.lax.scan(lambda s, _: (update(s, batch, w)[0], None), ts, None,
                                           length=n_updates)[0])
    t0 = time.perf_counter()
    dt = timed(many, learner, reps=reps) / n_updates
    print(f"  {cfg.net.trunk}: {n_updates} updates compiled and timed in {time.perf_counter() - t0:.1f} s", flush=True)

    rot = batch.action[:, :1]
    if cfg.dqn.symmetric_grasp_label:
        rot = jnp.concatenate([rot, (rot + cfg.net.n_rotations // 2) % cfg.net.n_rotations], 1)
    has_next = hasattr(batch, "next_height")  # "actor": no next states; the parts time the same pass
    next_c, next_h = (batch.next_color, batch.next_height) if has_next else (batch.color, batch.height)
    next_h = next_h.astype(jnp.float32)
    target = lambda v: apply(v, next_c, next_h, False)  # noqa: E731  (B, R, H, W)
    online = lambda v: apply(v, batch.color, batch.height.astype(jnp.float32), True,  # noqa: E731
                             mutable=["batch_stats"], rotations=rot)[0]
    passes = 0 if cfg.dqn.gamma == 0 or not has_next else (2 if cfg.dqn.double_q else 1)
    if passes and cfg.stage1.bootstrap == "actor_argmax":
        passes = 1 / cfg.net.n_rotations  # the target network at one rotation of each next state
    f_target, f_online = forward_flops(target, variables), forward_flops(online, variables)
    flops = passes * f_target + 3 * f_online
    result = {"trunk": cfg.net.trunk, "dtype": cfg.net.dtype, "batch_size": cfg.dqn.batch_size,
              "heightmap_px": H, "rotations": cfg.net.n_rotations, "half_turn": cfg.net.half_turn,
              "update_flops": flops, "target_pass_flops": f_target,
              "online_forward_flops": f_online, "target_passes": passes, "xla_flops": None, "update_s": dt,
              "updates_per_s": 1 / dt, "achieved_flops_per_s": flops / dt, "mfu": flops / dt / peak, "parts": {}}
    if not parts:
        return result
    t0 = time.perf_counter()

    # The target pass in its three parts: rotated copies of the inputs, trunks + head, Q maps
    # back in heightmap coordinates (vags_jax.nets.qnet, steps 1-5).
    b, R = next_h.shape[0], cfg.net.n_rotations
    geo = trunk_geometry(cfg.net.trunk, cfg.net.small_width)
    p = padded_size(H, geo.stride)
    theta = rotation_angles(jnp.broadcast_to(jnp.arange(R), (b, R)), R, cfg.net.half_turn)
    rotate_in = jax.jit(lambda c, h: rotated_inputs(pad_inputs(c, h, p), theta))
    x = rotate_in(next_c, next_h)
    trunks = jax.jit(lambda v, x: net.apply(v, x, False, method=net.coarse_q))
    coarse = trunks(variables, x)
    back = jax.jit(lambda c: coarse_to_heightmap(c, theta.reshape(-1), p, H, H, geo))
    grad = jax.jit(jax.grad(lambda prm: jnp.sum(dqn.q_at_action(
        online({"params": prm, "batch_stats": variables["batch_stats"]}), batch.action.at[:, 0].set(0)))))
    result["parts"] = {
        "target_pass_s": timed(jax.jit(target), variables, reps=reps),
        "target_rotate_inputs_s": timed(rotate_in, next_c, next_h, reps=reps),
        "target_trunks_and_head_s": timed(trunks, variables, x, reps=reps),
        "target_to_heightmap_s": timed(back, coarse, reps=reps),
        "online_forward_backward_s": timed(grad, variables["params"], reps=reps),
    }
    result["xla_flops"] = flops_of(jax.jit(lambda ts: update(ts, batch, w)[0]), learner)  # one update
    print(f"  {cfg.net.trunk}: parts and XLA's count compiled and timed in {time.perf_counter() - t0:.1f} s", flush=True)
    return result


def phases(st, state, reps: int) -> dict:
    """Seconds of each phase of one stage-1 iteration, each jitted alone (module docstring)."""
    cfg, env = st.cfg, st.env
    s1 = cfg.stage1
    s = state.env
    key = jax.random.PRNGKey(7)
    eps = exploration.epsilon(state.iteration, cfg.exploration)
    every = jnp.ones((s.n_worlds,), bool)

    def forward(learner, s):  # as the stage acts: with net.forward_needed_only, the greedy worlds only
        return st.act(learner, s, every, key, eps)[0]

    action = jax.jit(forward)(state.learner, s)
    none = jnp.zeros((s.n_worlds,), bool)
    n_obj = jnp.full((s.n_worlds,), s1.min_objects, jnp.int32)
    physics = jax.jit(lambda s, a: env.step_grasp_or_reset(s, a[:, 1:], a[:, 0], none, key, n_obj, observe=False)[0])
    s2 = physics(s, action)
    render = jax.jit(lambda s2: env.with_observation(s2, key if cfg.camera.noise.enabled else None))
    trans = st.transitions(s, action, jnp.zeros((s.n_worlds,)), s, none)
    add = jax.jit(lambda b, t: replay.add(b, t, mask=~none))
    keys = jax.random.split(key, s1.updates_per_iteration)
    sample = jax.jit(lambda b: jax.lax.scan(
        lambda c, k: (c, replay.sample(b, k, cfg.dqn.batch_size, cfg.replay.alpha, cfg.replay.beta)[2].sum()),
        0, keys)[1])
    _, batch, w = replay.sample(state.replay, key, cfg.dqn.batch_size, cfg.replay.alpha, cfg.replay.beta)
    updates = jax.jit(lambda ts: jax.lax.scan(lambda c, _: (st.update(c, batch, w)[0], None), ts, None,
                                              length=s1.updates_per_iteration)[0])
    return {
        "forward_and_choice_s": timed(jax.jit(forward), state.learner, s, reps=reps),
        "physics_s": timed(physics, s, action, reps=reps),
        "render_heightmaps_s": timed(render, s2, reps=reps),
        "replay_add_s": timed(add, state.replay, trans, reps=reps),
        "replay_sample_s": timed(sample, state.replay, reps=reps),
        "updates_s": timed(updates, state.learner, reps=reps),
    }


def host_work(state, metrics, chunk: int) -> tuple[float, float]:
    """(a chunk's metrics copy to the host spread over its ``chunk`` iterations, one checkpoint
    save of ``state``), seconds."""
    from vags_jax.stages import checkpoint  # the environment's packages (MuJoCo) load only here

    t = time.perf_counter()
    jax.device_get(metrics)
    copy_s = time.perf_counter() - t
    with tempfile.TemporaryDirectory() as d:
        t = time.perf_counter()
        checkpoint.save(d, 1, state)
        save_s = time.perf_counter() - t
    return copy_s / chunk, save_s


def whole_iterations(cfg, iterations: int, reps: int) -> dict:
    """Parts 1 and 2 of the docstring: stage 1's attempts/s over whole iterations and its phases."""
    from vags_jax.stages import pipeline  # the environment's packages (MuJoCo) load only here
    from vags_jax.stages.stage1 import Stage1

    s1 = cfg.stage1
    st = Stage1(cfg)
    state = st.init(jax.random.PRNGKey(cfg.seed))
    n = max(iterations, -(-s1.learning_starts // s1.n_worlds) + 1)  # the first chunk fills replay
    t = time.perf_counter()
    state, _ = st.run(state, n)
    jax.block_until_ready(state)
    first_s = time.perf_counter() - t
    a0 = int(state.attempts)
    t = time.perf_counter()
    state, metrics = st.run(state, n)
    jax.block_until_ready(state)
    wall = time.perf_counter() - t
    attempts = int(state.attempts) - a0
    updates = float(np.sum(metrics["updates"]))
    it_s = wall / n
    print(f"stage 1: {attempts / wall:,.0f} grasp attempts/s ({attempts} attempts, {updates:.0f} updates in "
          f"{wall:.2f} s; {it_s * 1e3:.1f} ms per iteration; first chunk with compiling {first_s:.1f} s)", flush=True)

    ph = phases(st, state, reps)
    ph["rest_of_iteration_s"] = it_s - sum(ph.values())
    ph["metrics_to_host_per_iteration_s"], save_s = host_work(state, metrics, pipeline.default_chunk(s1.iterations))
    for k, v in ph.items():
        print(f"  {k[:-2].replace('_', ' '):28s} {v * 1e3:8.2f} ms  {100 * v / it_s:5.1f} %", flush=True)
    from vags_jax.stages.driver import CHECKPOINT_MINUTES

    print(f"  one checkpoint save {save_s:.2f} s (train.py saves every {CHECKPOINT_MINUTES:g} minutes and at "
          f"a stage's end, not per chunk)", flush=True)

    return {"iterations_timed": n, "wall_s": wall, "attempts": attempts, "attempts_per_s": attempts / wall,
            "iteration_s": it_s, "first_chunk_s": first_s, "phases": ph, "checkpoint_save_s": save_s}


def vags_stage_phases(stage, state, reps: int) -> dict:
    """Seconds of each phase of one stage-2/3 iteration (``VagsStage._iteration``), each jitted
    alone on ``state``'s arrays: VANet's pass, exploration and the gate (with the success net's
    estimate); the attempt's plan (every world's close view, its fused map and the close-view
    planner's pass); the attempts' physics (no render); rendering + heightmaps of every world;
    GDNet's greedy pass over the new views; the iteration's updates of VANet, GDNet and the
    success net.  Replay adds and the calibration are left in the rest of the iteration."""
    from vags_jax.policies.decision import plan_attempt  # the environment's packages (MuJoCo) load only here

    cfg, env, flags = stage.cfg, stage.env, stage.flags
    key = jax.random.PRNGKey(7)
    eps = exploration.epsilon(state.iteration, cfg.exploration)

    def choose(st):
        s = st.env
        q_view = stage._in_groups(lambda c, h: stage._apply_vanet(stage._vars(st.vanet), c, h, False),
                                  s.color, s.height)
        view = exploration.select_pixel(key, q_view, s.height, eps, cfg.exploration)[0]
        grasp = exploration.select_grasp_from_greedy(key, st.gd_grasp, cfg.net.n_rotations, s.height, eps,
                                                     cfg.exploration)[0]
        grasp = jnp.where(flags.train_gdnet, grasp, st.gd_grasp)
        return stage._decision(st, q_view, grasp, view, flags.stage3)[0]

    def plan(st, decision):
        return plan_attempt(cfg, env, st.env, decision, key, stage._gdnet_q(st.gdnet), st.ggcnn, stage.ggcnn,
                            stage.close_success_q(st.success))[0]

    s = state.env
    none = jnp.zeros((s.n_worlds,), bool)
    n_obj = jnp.full((s.n_worlds,), stage.stage.min_objects, jnp.int32)
    choose_jit, plan_jit = jax.jit(choose), jax.jit(plan)
    decision = choose_jit(state)
    attempt = plan_jit(state, decision)
    physics = jax.jit(lambda s, a: env.step_attempt_or_reset(s, a, none, key, n_obj, observe=False)[0])
    s2 = physics(s, attempt)
    render = jax.jit(lambda s2: env.with_observation(s2, key if cfg.camera.noise.enabled else None))
    greedy_next = jax.jit(lambda st, s2: stage._greedy(st.gdnet, s2))
    learn = jax.jit(lambda st: stage._learn(st, st.vanet_replay, st.gdnet_replay, key, flags.train_gdnet))
    return {
        "vanet_and_gate_s": timed(choose_jit, state, reps=reps),
        "attempt_plan_close_view_s": timed(plan_jit, state, decision, reps=reps),
        "physics_s": timed(physics, s, attempt, reps=reps),
        "render_heightmaps_s": timed(render, s2, reps=reps),
        "gdnet_next_views_s": timed(greedy_next, state, s2, reps=reps),
        "updates_s": timed(learn, state, reps=reps),
    }


def vags_stage_iterations(cfg, run_dir: str, name: str, iterations: int, programs=None,
                          chunk: Optional[int] = None, reps: int = 0) -> dict:
    """Stage 2's or 3's grasp attempts/s over whole iterations (collect + learn), run in chunks of
    the length ``train.py`` uses, from the networks RUN's earlier stages saved (as ``train.py
    --stage`` restores them: untrained networks would not grasp, and the resets that grasps
    bring would be missing from the timing).  Replay is filled to the stage's
    ``learning_starts`` first; then at least ``iterations`` iterations are timed.  ``reps`` > 0:
    then each phase of an iteration over ``reps`` calls (``vags_stage_phases``; each phase a
    compile of its own).  ``programs``: a ``stages.programs.Programs`` whose compiled stage to
    reuse; ``chunk``: iterations per chunk (``train.py --chunk``; default: its default)."""
    from vags_jax.stages import driver, pipeline, rundir  # the environment's packages (MuJoCo) load only here
    from vags_jax.stages.programs import Programs

    sc = getattr(cfg, name)
    stage = (programs or Programs()).stage(name, cfg)
    fns = pipeline.stage_fns(name, stage)
    state = fns.init(rundir.stage_key(cfg, name), driver.handover_from_disk(run_dir, cfg, name, pipeline.Handover()))
    chunk = chunk or pipeline.default_chunk(rundir.total(cfg, name))
    chunks = lambda n: -(-n // chunk)  # noqa: E731  (whole chunks covering n iterations)
    t = time.perf_counter()
    state, _ = pipeline.run_stage(fns, state, chunks(-(-sc.learning_starts // sc.n_worlds) + 1) * chunk, chunk)
    jax.block_until_ready(state)
    first_s = time.perf_counter() - t
    a0, n = int(state.attempts), chunks(iterations) * chunk
    t = time.perf_counter()
    state, metrics = pipeline.run_stage(fns, state, n, chunk)
    jax.block_until_ready(state)
    wall = time.perf_counter() - t
    attempts = int(state.attempts) - a0
    updates = float(sum(np.sum(m["updates"]) for m in metrics))
    print(f"{name}: {attempts / wall:,.0f} grasp attempts/s ({attempts} attempts, {updates:.0f} updates of its "
          f"networks in {wall:.2f} s over {n} iterations in chunks of {chunk}; {wall / n * 1e3:.1f} ms per "
          f"iteration; filling replay, compiling included, {first_s:.1f} s)", flush=True)
    result = {"stage": name, "run": run_dir, "iterations_timed": n, "chunk": chunk, "wall_s": wall,
              "attempts": attempts, "updates": updates, "attempts_per_s": attempts / wall, "iteration_s": wall / n,
              "first_chunks_s": first_s}
    if reps > 0:
        ph = vags_stage_phases(stage, state, reps)
        ph["rest_of_iteration_s"] = wall / n - sum(ph.values())
        for k, v in ph.items():
            print(f"  {k[:-2].replace('_', ' '):28s} {v * 1e3:8.2f} ms  {100 * v / (wall / n):5.1f} %", flush=True)
        result["phases"] = ph
    return result


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--config", default="gpu")
    p.add_argument("--set", nargs="*", default=[], metavar="SECTION.FIELD=VALUE")
    p.add_argument("--iterations", type=int, default=8, help="iterations per timed chunk (default 8)")
    p.add_argument("--reps", type=int, default=5, help="calls per phase timing (default 5)")
    p.add_argument("--trunks", default="small,densenet121", help="trunks for the update MFU (comma-separated)")
    p.add_argument("--matmul", type=int, default=None, help="side of the peak matmul (default 8192 GPU, 1024 CPU)")
    p.add_argument("--cache-dir", default=None, help="compile cache (as train.py's); 'off' to measure cold")
    p.add_argument("--out", default=None, help="JSON file for every figure")
    p.add_argument("--updates-only", action="store_true",
                   help="only the matmul peak and the update MFU of each trunk (no environment, no MuJoCo)")
    p.add_argument("--no-parts", action="store_true",
                   help="the update MFU without its parts and XLA's FLOP count (one compile per trunk)")
    p.add_argument("--stage", default="stage1", choices=("stage1", "stage2", "stage3"),
                   help="stage2 / stage3: that stage's whole iterations and phases from --run's saved networks")
    p.add_argument("--run", default=None, help="a run directory (its config.json and the earlier stages' "
                   "checkpoints): needed for --stage stage2 / stage3, which start from its networks")
    args = p.parse_args(argv)
    if args.stage != "stage1" and (args.run is None or args.updates_only):
        p.error(f"--stage {args.stage} times that stage from a trained run's networks: give --run RUN "
                f"(a run whose earlier stages are trained), without --updates-only")
    compile_cache.enable(args.cache_dir)
    if args.run is not None:
        from vags_jax.stages import checkpoint

        cfg = C.replace(checkpoint.load_config(args.run), **C.parse_overrides(args.set))
    else:
        cfg = C.replace(C.preset(args.config), **C.parse_overrides(args.set))
    s1 = getattr(cfg, args.stage)  # the timed stage's worlds and updates
    on_gpu = jax.devices()[0].platform == "gpu"
    source = args.run if args.run is not None else args.config
    print(f"device: {jax.devices()[0].device_kind}; config {source} {' '.join(args.set)}; {args.stage}: "
          f"{s1.n_worlds} worlds, {s1.updates_per_iteration} updates of batch {cfg.dqn.batch_size} per iteration",
          flush=True)

    result = {"device": jax.devices()[0].device_kind, "config": source, "overrides": args.set,
              "n_worlds": s1.n_worlds, "updates_per_iteration": s1.updates_per_iteration,
              "batch_size": cfg.dqn.batch_size, "updates_only": args.updates_only}
    if args.stage != "stage1":
        try:
            result.update(vags_stage_iterations(cfg, args.run, args.stage, args.iterations, reps=args.reps))
        except ValueError as e:  # CheckpointError: the run lacks the stages this one starts from
            p.error(str(e))
    elif not args.updates_only:
        result.update(whole_iterations(cfg, args.iterations, args.reps))
    peak = matmul_peak(args.matmul or (8192 if on_gpu else 1024))
    print(f"bf16 matmul peak measured: {peak / 1e12:.1f} TFLOP/s", flush=True)
    mfu = []
    for trunk in [t for t in args.trunks.split(",") if t]:
        tcfg = C.replace(cfg, **{"net.trunk": trunk, "net.dtype": "bfloat16"})
        r = update_mfu(tcfg, peak, s1.updates_per_iteration, parts=not args.no_parts)
        mfu.append(r)
        xla = "XLA's count skipped" if r["xla_flops"] is None else f"XLA counts {r['xla_flops'] / 1e9:.1f}"
        print(f"update MFU, {trunk}: {r['update_flops'] / 1e9:.1f} GFLOP per update (model; {xla}), "
              f"{r['updates_per_s']:.1f} updates/s, "
              f"{r['achieved_flops_per_s'] / 1e12:.2f} TFLOP/s = {100 * r['mfu']:.1f} % of the peak", flush=True)
        for k, v in r["parts"].items():
            print(f"    {k[:-2].replace('_', ' '):38s} {v * 1e3:8.2f} ms  {100 * v / r['update_s']:5.1f} % of an update",
                  flush=True)

    result.update(matmul_peak_flops_per_s=peak, update_mfu=mfu, date=time.strftime("%Y-%m-%d"))
    if args.out:
        os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
        with open(args.out, "w") as f:
            json.dump(result, f, indent=2)
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
