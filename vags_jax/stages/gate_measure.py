"""Measure the "rate" gate's table on a trained run (``vags_jax.policies.rate_gate``):

    python -m vags_jax.stages.gate_measure --run runs/gpu        # writes runs/gpu/gate.json
    python -m vags_jax.stages.gate_measure --run runs/gpu --refit --bins 16   # the same states, finer bins
    python eval.py --run runs/gpu --set vags.gate=rate

Why: the "success" gate's estimates are checked during stages 2-3 only where the gate chose
that branch, so the success net is least checked exactly where the gate decides (a state sent
to a move never shows its direct outcome), and the share of moves swings from one training
run to the next (bench/RESULTS.md, "Viewpoints that pay, fourth look").  The simulator is pure,
so after training both branches run from the same state:

* fresh piles of stage 3's object counts (``worlds``); GDNet grasps directly for ``steps``
  attempts, and every state on the way is measured;
* from each state the direct grasp and the grasp after a move (VANet's viewpoint, or
  ``vags.viewpoint``; the configured close-view planner) each run in their own copy of the
  physics, with the benchmark's modelled robot seconds (``MotionTimeModel``; a failed grasp
  also pays its return to the global pose); the grasp after a move is scored by
  ``vags.close_score`` (``--close-score``) and the direct grasp planned by
  ``vags.direct_score`` (``--direct-score``), both recorded in RUN/gate.json;
* ``rate_gate.fit`` bins the success net's raw p_direct and writes the table to RUN/gate.json;
* ``--follow moved`` (a diagnostic, written under ``--out``): the piles follow the grasps after
  a move instead, as in rounds that always move, to see how a branch's failures compound;
* with ``vags.stage3_gdnet_pick="rate"`` the table is measured again with the GDNet stage 3
  started from (stage 2's), and with stage 2's for the direct grasps and stage 3's (which
  learned on fused close views) for those after a move ("split"); the GDNets whose table picks
  most per second are the run's (``rundir.load_vags`` reads the pick from RUN/gate.json).
Shapes: B = ``worlds``.
"""
from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import time
from typing import Optional

import jax
import jax.numpy as jnp
import numpy as np

from vags_jax import cli
from vags_jax.benchmark.metrics import MotionTimeModel
from vags_jax.benchmark.protocol import return_distance
from vags_jax.config import GateTable, replace
from vags_jax.env import VagsEnv, where_worlds
from vags_jax.perception.topdown import TopDown
from vags_jax.policies import rate_gate
from vags_jax.policies.catalog import vags_params
from vags_jax.policies.decision import (CLOSE_SCORES, DIRECT_SCORES, GATE_ESTIMATES, VagsNets, close_view_grasp,
                                        decide, direct_grasp, greedy, success_estimates)
from vags_jax.rl.exploration import random_object_cell
from vags_jax.stages import checkpoint, rundir
from vags_jax.stages.programs import Programs

PROG = "python -m vags_jax.stages.gate_measure"
STATES_FILE = rate_gate.STATES_FILE
FOLLOW = ("direct", "moved")  # the branch the piles follow from one measured state to the next
# Diagnostic branches (``bench/gate_headroom.py``), never in the pipeline's table: "oracle", the
# direct planner on ground-truth top-down maps (the most any viewpoint could show it); "random",
# the move and close-view grasp of "moved" but to a uniformly random object cell; "planned", no
# move, the success net's direct grasp on the global view (``vags.direct_score="success"``), to
# tell a move's gain from its planner's.
EXTRA_BRANCHES = ("oracle", "random", "planned")


def make_collect(cfg, env: VagsEnv, nets: VagsNets, extra: tuple = ()):
    """-> jitted ``(params, key, state, follow_moved) -> (next state, per-world dict of (B,) arrays)``:
    ``p_direct`` the success net's estimate of the direct grasp (``vags.gate_estimate``; the
    grasp is ``vags.direct_score``'s, ``decision.direct_grasp``), and
    every other estimate and GDNet's Q there (``decision.success_estimates``: ``p_<estimate>``,
    ``p_best``, ``q_direct``) for analysis; for each branch ("direct",
    "moved") its ``success``, ``lost`` (objects that left the table without a grasp),
    ``motions``, ``travel`` (m, camera move + approach + descend + lift) and ``back`` (m, the
    return to the global pose after a failure); ``objects`` (int32) on the table before the
    attempt; ``live`` worlds with objects and no physics error.  Under a ``direct_score`` other
    than "q" a third branch, "gdnet", grasps at GDNet's argmax from the same state (the paper's direct
    grasp, for comparing the two planners state by state).  The next state follows the
    direct grasp, or the grasp after the move where follow_moved (() bool, traced: one program
    for both) is set: the branch's own outcome, re-observed, so the program simulates each
    attempt once (two grasp loops, not three: a third of its compile and run time; three with
    the "gdnet" branch).  ``extra``: any of ``EXTRA_BRANCHES``, each one more branch from the
    same state (the default program, and its keys, are unchanged without them)."""
    unknown = [b for b in extra if b not in EXTRA_BRANCHES]
    if unknown:
        raise ValueError(f"extra branches must be among {EXTRA_BRANCHES}, got {unknown}")
    start = jnp.asarray(cfg.camera.global_position, jnp.float32)
    topdown = TopDown(env) if "oracle" in extra else None

    def branch(name, state, attempt):
        """-> (the state after ``attempt``, unobserved; its per-world rows)."""
        after, r = env.step_attempt(state, attempt, observe=False)
        back = jnp.where(r.success, 0.0, return_distance(cfg, attempt.position, start))
        return after, {f"{name}_success": r.success, f"{name}_lost": env.knocked_off(state, after, r.success),
                       f"{name}_motions": attempt.motions,
                       f"{name}_travel": r.approach + r.descend + r.lift + attempt.view_travel, f"{name}_back": back}

    def extra_rows(params, key, state, q_grasp, q_success):
        """The rows of the ``extra`` branches from ``state`` (q_grasp, q_success: GDNet's and the
        success net's maps of its global view)."""
        rows = {}
        if "oracle" in extra:
            color, height = topdown.maps(state.sim)
            qg, qv, qs = nets.q_maps(params, color, height)
            g = decide(qg, qv, 0.0, qs, "q", viewpoint=cfg.vags.viewpoint, direct_score=cfg.vags.direct_score,
                       half_turn=cfg.grasp.half_turn).grasp
            pose = env.grasp_pose(state.replace(height=height), g[:, 1:], g[:, 0])
            rows.update(branch("oracle", state, env.direct_attempt(*pose))[1])
        if "random" in extra:
            k_cell, k_img = jax.random.split(key)
            cell = jax.vmap(lambda k, h: random_object_cell(k, h, cfg.exploration))(
                jax.random.split(k_cell, state.n_worlds), state.height)
            view = jnp.stack(jnp.unravel_index(cell, state.height.shape[1:]), -1).astype(jnp.int32)
            moved, _ = close_view_grasp(cfg, env, state, view, k_img, nets.close_q(params), params.get("ggcnn"),
                                        nets.ggcnn, nets.close_success_q(params))
            rows.update(branch("random", state, moved)[1])
        if "planned" in extra:
            g = direct_grasp(q_grasp, q_success, "success", cfg.grasp.half_turn)[0]
            rows.update(branch("planned", state, env.direct_attempt(*env.grasp_pose(state, g[:, 1:], g[:, 0])))[1])
        return rows

    def step(params, key, state, follow_moved):
        k_img, k_obs = jax.random.split(key)
        q_grasp, q_view, q_success = nets.q_maps(params, state.color, state.height)
        d = decide(q_grasp, q_view, 0.0, q_success, "q", viewpoint=cfg.vags.viewpoint,
                   direct_score=cfg.vags.direct_score, half_turn=cfg.grasp.half_turn)
        pos, yaw = env.grasp_pose(state, d.grasp[:, 1:], d.grasp[:, 0])
        direct = env.direct_attempt(pos, yaw)
        moved, _ = close_view_grasp(cfg, env, state, d.view, k_img, nets.close_q(params),
                                    params.get("ggcnn"), nets.ggcnn, nets.close_success_q(params))
        after_direct, rows_direct = branch("direct", state, direct)
        after_moved, rows_moved = branch("moved", state, moved)
        if cfg.vags.direct_score != "q":  # the paper's direct grasp on the same state, for comparison
            g = greedy(q_grasp)[0]
            _, rows_gdnet = branch("gdnet", state, env.direct_attempt(*env.grasp_pose(state, g[:, 1:], g[:, 0])))
            rows_direct = {**rows_direct, **rows_gdnet}
        if extra:
            rows_direct = {**rows_direct, **extra_rows(params, jax.random.fold_in(key, 1), state, q_grasp,
                                                        q_success)}
        estimates = success_estimates(q_success, q_grasp, d.grasp, cfg.grasp.half_turn)
        out = {"p_direct": estimates[f"p_{cfg.vags.gate_estimate}"], **estimates,
               "objects": env.n_remaining(state), "live": (env.n_remaining(state) > 0) & ~state.sim.error,
               **rows_direct, **rows_moved}
        followed = where_worlds(jnp.broadcast_to(follow_moved, (state.n_worlds,)), after_moved, after_direct)
        return env.with_observation(followed, k_obs if cfg.camera.noise.enabled else None), out

    return jax.jit(step)


def seconds(rows: dict, name: str, time_model: MotionTimeModel) -> np.ndarray:
    """(N,) modelled robot seconds of one attempt per state on branch ``name``."""
    return time_model.round_seconds(1, rows[f"{name}_success"].astype(np.float64), rows[f"{name}_motions"],
                                    rows[f"{name}_travel"], rows[f"{name}_back"])


def measure_config(run_cfg, estimate: Optional[str] = None, close_score: Optional[str] = None,
                   direct_score: Optional[str] = None):
    """The config the table is measured under: the run's, with the gate's inputs as the "success"
    gate reads them (the raw success net and VANet's viewpoint), p_direct the success net's
    ``estimate`` (None: the run's ``vags.gate_estimate``), the grasps after a move scored by
    ``close_score`` and the direct grasps planned by ``direct_score`` (None: the run's
    ``vags.close_score`` / ``vags.direct_score``)."""
    over = {"vags.gate": "success", "vags.view_estimate": "vanet"}
    if estimate is not None:
        over["vags.gate_estimate"] = estimate
    if close_score is not None:
        over["vags.close_score"] = close_score
    if direct_score is not None:
        over["vags.direct_score"] = direct_score
    return replace(run_cfg, **over)


def due(run_dir: str, cfg, stage3_finished: Optional[bool] = None) -> bool:
    """train.py's pipeline measures the table now: ``gate_table.worlds`` > 0, stage 3 finished
    (``stage3_finished``, else as its checkpoints on disk say), and RUN/gate.json missing or
    measured on other networks."""
    if stage3_finished is None:
        stage3_finished = rundir.progress(run_dir, "stage3") >= rundir.total(cfg, "stage3")
    if cfg.gate_table.worlds == 0 or not stage3_finished:
        return False
    steps = checkpoint.checkpoint_steps(rundir.networks_dir(run_dir, "stage3"))
    return bool(steps) and rate_gate.load(run_dir, rundir.networks_source("stage3", max(steps))) is None


def _collect_program(cfg, programs: Programs, extra: tuple = ()):
    """(env, the jitted collect step with ``extra`` branches) of measure config ``cfg``, built once per ``programs``."""
    env = programs.env(cfg)
    key = programs.cfg_key("gate_collect" + "".join(f"+{b}" for b in extra), cfg)
    return env, programs.get(key, lambda: make_collect(cfg, env, VagsNets(cfg), extra))


def _first_piles(env: VagsEnv, cfg, worlds: int, seed: int):
    """-> (key, the fresh piles of stage 3's object counts the table starts from)."""
    key = jax.random.PRNGKey(seed)
    k_n, k_reset, key = jax.random.split(key, 3)
    n_obj = jax.random.randint(k_n, (worlds,), cfg.stage3.min_objects, cfg.stage3.max_objects + 1)
    return key, env.reset(k_reset, n_obj)


def compile_collect(run_cfg, networks, programs=None) -> None:
    """Compiles (never runs) the table's collect step for a run of config ``run_cfg`` into the
    compile cache, from ``networks`` (``rundir.VagsNetworks``; only their shapes matter, so
    placeholders do): every pick of GDNets runs this one program.  The first piles are reset for
    real (``gate_table.worlds`` of them).  ``stages.precompile --stages gate`` calls it."""
    g = run_cfg.gate_table
    cfg = measure_config(run_cfg)
    env, step = _collect_program(cfg, Programs() if programs is None else programs)
    key, state = _first_piles(env, cfg, g.worlds or GateTable().worlds, g.seed)
    step.lower(vags_params(networks, cfg), key, state, jnp.asarray(False)).compile()


def measure(run_dir: str, worlds=None, steps=None, bins=None, seed=None, log=print, programs=None,
            count_lost=None, gdnet="stage3", follow="direct", estimate=None, close_score=None, direct_score=None,
            piles=None, extra=()):
    """The gate table of a trained run (stage 3's networks, else stage 2's) -> (GateTable, meta,
    states): ``states`` the (N,) per-state arrays of the live states the table was fit on, with
    each state's ``world`` and ``attempt`` (its index along the pile).
    worlds / steps / bins / seed / count_lost default to the run's ``gate_table`` config; programs: a
    ``programs.Programs`` whose compiled collect step is reused (train.py's pipeline); gdnet:
    the GDNets of stage 3's networks (``rundir.GDNET_PICKS``: "stage2" grasps with stage 2's,
    "split" directly with stage 2's and after a move with stage 3's); follow: the branch the
    piles follow between attempts (``FOLLOW``; "moved" makes a diagnostic, not the gate's table);
    estimate: the success estimate the table bins (``config.Vags.gate_estimate``; None: the
    run's), recorded as meta["estimate"]; close_score: what scores the grasps after a move
    (``config.Vags.close_score``; None: the run's), recorded as meta["close_score"];
    direct_score: what plans the direct grasps (``config.Vags.direct_score``; None: the run's),
    recorded as meta["direct_score"]; piles: a dict that keeps the first piles by (worlds, seed),
    so that calls of one config reset them once (``measure_picked``'s candidates); extra: any of
    ``EXTRA_BRANCHES``, measured from the same states (``<branch>_success``, ``_lost``, ``_seconds``
    in ``states``; the table is fit on "direct" and "moved" alone, as without them)."""
    if follow not in FOLLOW:
        raise ValueError(f"follow must be one of {FOLLOW}, got {follow!r}")
    run_cfg = checkpoint.load_config(run_dir)
    g = run_cfg.gate_table
    worlds, steps = worlds or g.worlds or GateTable().worlds, steps or g.steps
    bins, seed = bins or g.bins, g.seed if seed is None else seed
    count_lost = g.count_lost if count_lost is None else count_lost
    cfg = measure_config(run_cfg, estimate, close_score, direct_score)
    networks = rundir.load_vags(run_dir, cfg, gdnet=gdnet)
    params = vags_params(networks, cfg)  # ValueError without a success net
    stage = cfg.stage3
    env, step = _collect_program(cfg, Programs() if programs is None else programs, tuple(extra))
    t0 = time.time()
    piles = {} if piles is None else piles
    if (worlds, seed) not in piles:  # the collect step does not donate its input: the piles can be reused
        piles[worlds, seed] = _first_piles(env, cfg, worlds, seed)
    key, state = piles[worlds, seed]
    parts: dict[str, list] = {}
    for t in range(steps):
        key, k = jax.random.split(key)
        state, out = step(params, k, state, jnp.asarray(follow == "moved"))
        out = {**jax.device_get(out), "world": np.arange(worlds), "attempt": np.full(worlds, t)}
        for name, v in out.items():
            parts.setdefault(name, []).append(np.asarray(v))
        log(f"gate table: attempt {t + 1}/{steps} in {worlds} worlds, {time.time() - t0:.0f} s")
    rows = {k: np.concatenate(v) for k, v in parts.items()}
    live = rows["live"].astype(bool)
    rows = {k: v[live] for k, v in rows.items()}
    tm = MotionTimeModel.from_config(cfg)
    rows["direct_seconds"], rows["moved_seconds"] = seconds(rows, "direct", tm), seconds(rows, "moved", tm)
    more = [b for b in ("gdnet", *EXTRA_BRANCHES) if f"{b}_success" in rows]
    for b in more:
        rows[f"{b}_seconds"] = seconds(rows, b, tm)
    more_rows = tuple(f"{b}_{k}" for b in more for k in ("success", "lost", "seconds"))
    table = rate_gate.fit(rows["p_direct"], rows["direct_success"], rows["direct_seconds"],
                          rows["moved_success"], rows["moved_seconds"], bins,
                          lost_direct=rows["direct_lost"], lost_moved=rows["moved_lost"], count_lost=count_lost)
    meta = {"networks": networks.source, "gdnet": networks.gdnet_source, "close_gdnet": networks.close_source,
            "worlds": worlds, "steps": steps, "seed": seed,
            "objects": [stage.min_objects, stage.max_objects], "live_states": int(live.sum()),
            "viewpoint": cfg.vags.viewpoint, "local_planner": cfg.vags.local_planner,
            "close_region": cfg.vags.close_region, "close_score": cfg.vags.close_score,
            "direct_score": cfg.vags.direct_score, "follow": follow,
            "estimate": cfg.vags.gate_estimate,
            "lost": rate_gate.paired_lost(table, rows["p_direct"], rows["direct_lost"], rows["moved_lost"]),
            "wall_s": round(time.time() - t0, 1), "device": str(jax.devices()[0])}
    states = {k: rows[k] for k in ("p_direct", "direct_success", "moved_success", "direct_lost", "moved_lost",
                                   "direct_seconds", "moved_seconds", "objects", "world", "attempt", "p_best",
                                   "q_direct", *(f"p_{e}" for e in GATE_ESTIMATES),
                                   *more_rows)}
    return table, meta, states


def save_states(run_dir: str, states: dict) -> str:
    """RUN/gate_states.npz: the per-state rows a table was fit on (``measure``), for analysis."""
    path = os.path.join(run_dir, STATES_FILE)
    np.savez(path, **states)
    return path


def describe(table, meta) -> str:
    """The table's bins and the objects each branch knocked off, as text."""
    return rate_gate.describe(table) + "\n" + rate_gate.describe_lost(meta["lost"])


def save_all(run_dir: str, table, meta, states) -> str:
    """RUN/gate.json (``rate_gate.save``) and RUN/gate_states.npz -> the path of gate.json."""
    save_states(run_dir, states)
    return rate_gate.save(run_dir, table, meta)


def pick_candidates(run_dir: str, cfg) -> tuple:
    """The ``rundir.GDNET_PICKS`` the table is measured with, stage 3's own first: with
    ``vags.stage3_gdnet_pick="rate"``, stage 3 having changed GDNet and both stages' networks
    kept, also "stage2" and (with the "gdnet" close-view planner) "split"; else ("stage3",)."""
    if not (cfg.vags.stage3_gdnet_pick == "rate" and cfg.vags.stage3_gdnet != "frozen"
            and rundir.vags_stages(run_dir) == ["stage3", "stage2"]):
        return ("stage3",)
    return ("stage3", "stage2") + (("split",) if cfg.vags.local_planner == "gdnet" else ())


def measure_picked(run_dir: str, log=print, programs=None, **kw):
    """``measure`` with each of ``pick_candidates``, keeping the table (and with it the GDNets,
    ``rundir.load_vags``) under which the gate picks most per second; a tie keeps the earlier
    -> (GateTable, meta, states); meta["gdnet_pick"] holds every candidate's GDNets, rate and
    success of the direct grasps and after a move."""
    programs = Programs() if programs is None else programs  # every measure shares its compiled step
    picks = pick_candidates(run_dir, checkpoint.load_config(run_dir))
    best, tried, piles = None, {}, {}
    for pick in picks:  # the same first piles for every candidate: reset once
        got = measure(run_dir, log=log, programs=programs, gdnet=pick, piles=piles, **kw)
        table, meta, states = got
        tried[pick] = {"gdnet": meta["gdnet"], "close_gdnet": meta["close_gdnet"], "rate": table.rate,
                       "direct_success": float(np.mean(states["direct_success"])),
                       "moved_success": float(np.mean(states["moved_success"]))}
        if best is None or table.rate > best[0].rate:
            best = got
    table, meta, states = best
    if len(picks) == 1:
        return table, meta, states
    log(f"GDNet kept: {describe_pick(meta)} (" + "; ".join(
        f"{k}: {3600 * v['rate']:.0f} picks/h, direct {100 * v['direct_success']:.1f} %, after a move "
        f"{100 * v['moved_success']:.1f} %" for k, v in tried.items()) + ")")
    return table, {**meta, "gdnet_pick": tried}, states


def describe_pick(meta: dict) -> str:
    """The GDNets a table was measured with, e.g. "stage2 step 80, after a move stage3 step 80"."""
    close = meta.get("close_gdnet", meta["gdnet"])
    return meta["gdnet"] + ("" if close == meta["gdnet"] else f", after a move {close}")


def measure_into(run_dir: str, log=print, programs=None, **kw):
    """``measure_picked`` then ``save_all`` -> (RUN/gate.json's path, GateTable, meta); logs the table."""
    table, meta, states = measure_picked(run_dir, log=log, programs=programs, **kw)
    for line in describe(table, meta).splitlines():
        log(line)
    return save_all(run_dir, table, meta, states), table, meta


def refit(run_dir: str, bins: int, estimate: Optional[str] = None):
    """RUN/gate.json fitted again from the states it was measured on (RUN/gate_states.npz, no
    simulation) over ``bins`` quantile bins of the success net's ``estimate`` (None: the one the
    table was fit on), keeping its networks and other settings -> (GateTable, meta, states), for
    ``save_all``; the states' p_direct becomes that estimate.  ValueError when the run has no
    table or no saved states, or states measured before that estimate was recorded."""
    d, states = rate_gate.read(run_dir), rate_gate.read_states(run_dir)
    path = os.path.join(run_dir, STATES_FILE)
    if d is None or states is None:
        raise ValueError(f"{run_dir} has no measured gate table ({rate_gate.GATE_FILE} and {STATES_FILE}) to fit "
                         f"again; measure one first: {PROG} --run {run_dir}")
    was = str(d.get("estimate", "grasp"))
    estimate = was if estimate is None else estimate
    if estimate != was:
        if f"p_{estimate}" not in states:
            raise ValueError(f"{path} holds no '{estimate}' estimates (measured before they were recorded): "
                             f"measure the table again with {PROG} --run {run_dir} --estimate {estimate}")
        states = {**states, "p_direct": states[f"p_{estimate}"]}
    old = rate_gate.from_dict(d)
    table = rate_gate.fit(states["p_direct"], states["direct_success"], states["direct_seconds"],
                          states["moved_success"], states["moved_seconds"], bins, lost_direct=states["direct_lost"],
                          lost_moved=states["moved_lost"], count_lost=old.count_lost)
    fields = {f.name for f in dataclasses.fields(rate_gate.GateTable)}
    meta = {k: v for k, v in d.items() if k not in fields}
    meta["lost"] = rate_gate.paired_lost(table, states["p_direct"], states["direct_lost"], states["moved_lost"])
    meta["refit"] = {"bins": bins, "from_bins": len(old.states), "from_estimate": was}
    meta["estimate"] = estimate
    return table, meta, states


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog=PROG, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--run", required=True, help="a train.py run with stage 2 or 3 networks")
    p.add_argument("--worlds", type=int, default=None, help="fresh piles (default: the run's gate_table.worlds, "
                   "or 256 where that is 0)")
    p.add_argument("--steps", type=int, default=None, help="direct attempts per pile, each state measured "
                   "(default: the run's gate_table.steps)")
    p.add_argument("--bins", type=int, default=None, help="quantile bins of p_direct (default: gate_table.bins)")
    p.add_argument("--seed", type=int, default=None, help="(default: gate_table.seed)")
    p.add_argument("--count-lost", action="store_true", default=None,
                   help="count each object a branch knocks off the table as a pick lost (default: gate_table.count_lost)")
    p.add_argument("--gdnet", choices=tuple(rundir.GDNET_PICKS), default=None,
                   help="measure with these GDNets of stage 3's networks only, and keep them: stage3 or stage2 "
                   "grasps with that stage's GDNet, split directly with stage 2's and after a move with stage 3's "
                   "(default: vags.stage3_gdnet_pick, e.g. rate: each of them, keeping the one that picks most)")
    p.add_argument("--follow", choices=FOLLOW, default="direct",
                   help="the branch the piles follow between measured attempts: direct (the gate's table) or moved "
                   "(a diagnostic of rounds that always move; needs --out)")
    p.add_argument("--out", default=None, help="write gate.json and gate_states.npz into this directory instead "
                   "of the run's (the run's table is left as it is)")
    p.add_argument("--refit", action="store_true",
                   help="no simulation: fit the run's table again from the states it was measured on "
                   "(RUN/gate_states.npz), over --bins bins, keeping its networks (seconds, not minutes)")
    p.add_argument("--estimate", choices=GATE_ESTIMATES, default=None,
                   help="the success net's estimate of GDNet's grasp the table bins (default: the run's "
                   "vags.gate_estimate; with --refit: the one the table was fit on); evaluate such a table "
                   "with --set vags.gate_estimate=...")
    p.add_argument("--close-score", choices=CLOSE_SCORES, default=None,
                   help="what scores the grasps after a move (default: the run's vags.close_score); evaluate such "
                   "a table with --set vags.close_score=...")
    p.add_argument("--direct-score", choices=DIRECT_SCORES, default=None,
                   help="what plans the direct grasps (default: the run's vags.direct_score); evaluate such a table "
                   "with --set vags.direct_score=...; with q_mean or success the states also hold GDNet's direct grasp "
                   "(gdnet_success, ...)")
    cli.add_cache_dir(p)
    args = p.parse_args(argv)
    error = cli.use_compile_cache(PROG, args.cache_dir)
    if error is not None:
        return error
    if args.refit and (args.bins is None or any(getattr(args, n) is not None for n in ("worlds", "steps", "seed",
                                                                                      "count_lost", "gdnet",
                                                                                      "close_score", "direct_score"))
                       or args.follow != "direct"):
        print(f"{PROG}: --refit fits the measured states again: it takes --bins (and --out, --estimate) only",
              file=sys.stderr)
        return 2
    if args.follow == "moved" and args.out is None:
        print(f"{PROG}: --follow moved measures a diagnostic, not the gate's table: give --out DIR for it "
              f"(RUN/gate.json is left as it is)", file=sys.stderr)
        return 2
    for name in ("worlds", "steps", "bins"):
        if getattr(args, name) is not None and getattr(args, name) < 1:
            print(f"{PROG}: --{name} must be at least 1, got {getattr(args, name)}", file=sys.stderr)
            return 2
    kw = dict(log=lambda m: print(m, file=sys.stderr, flush=True), worlds=args.worlds, steps=args.steps,
              bins=args.bins, seed=args.seed, count_lost=args.count_lost, follow=args.follow, estimate=args.estimate,
              close_score=args.close_score, direct_score=args.direct_score)
    try:
        if args.refit:
            table, meta, states = refit(args.run, args.bins, args.estimate)
        elif args.gdnet is None:
            table, meta, states = measure_picked(args.run, **kw)
        else:
            table, meta, states = measure(args.run, gdnet=args.gdnet, **kw)
    except (ValueError, checkpoint.CheckpointError, FileNotFoundError) as e:
        print(f"{PROG}: {e}", file=sys.stderr)
        return 2
    except jax.errors.JaxRuntimeError as e:  # XLA's out-of-memory; any other error keeps its traceback
        what = cli.out_of_memory(e)
        if what is None:
            raise
        cli.drop_failed_device_work()
        gate_file = os.path.join(args.run, rate_gate.GATE_FILE)
        print(f"{PROG}: error: out of accelerator memory ({what}): lower --worlds, or leave this process more "
              f"of the device (fewer processes beside it, or a larger XLA_PYTHON_CLIENT_MEM_FRACTION); "
              f"{gate_file} is unchanged", file=sys.stderr)
        return 1
    print(describe(table, meta))
    if args.out is not None:
        os.makedirs(args.out, exist_ok=True)
        meta = {**meta, "run": args.run}
    print(f"wrote {save_all(args.run if args.out is None else args.out, table, meta, states)} and {STATES_FILE} beside it")
    return 0


if __name__ == "__main__":
    sys.exit(main())
