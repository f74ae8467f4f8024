"""Pictures of VAGS deciding and grasping, round by round (``eval.py --record DIR``).

The recorded rounds replay the benchmark's scenes (the same per-round scene keys as
``Evaluator.run_groups``) step by step on the host, so that every intermediate map can be
kept: for each attempt of each recorded round, the global colour and height heightmaps,
GDNet's Q (max over rotations) and VANet's Q, the decision, the close depth image with
GG-CNN's smoothed quality / angle / width maps and its peak, the executed grasp and the
outcome (``vags_jax.benchmark.record``: one PNG per attempt, one JSON per round).  The policy's sensor
noise draws differ from the benchmark run's, so a recorded round may end differently from the
same round in the table.
"""
from __future__ import annotations

import os
from typing import Sequence

import jax
import jax.numpy as jnp
import numpy as np

from vags_jax.perception import camera
from vags_jax.config import Config
from vags_jax.env import where_worlds
from vags_jax.policies.decision import VagsNets
from vags_jax.ggcnn.planner import network_input
from vags_jax.ggcnn.process import postprocess
from vags_jax.benchmark.record import AttemptRecord, write_round


def _trace_fn(cfg: Config, env):
    nets = VagsNets(cfg)
    model = nets.ggcnn

    def trace(params, key, state):
        attempt, decision, close, q_grasp, q_view = nets.plan(params, key, env, state)
        cell = camera.world_xy_to_pixel(attempt.position[:, :2], cfg.workspace)
        info = {"q_grasp": q_grasp.max(axis=1), "grasp": decision.grasp, "q_max": decision.q_max,
                "score": decision.score, "q_view": q_view, "view": decision.view, "direct": decision.direct,
                "local_depth": close.image.depth, "color": state.color, "height": state.height, "cell": cell}
        if close.image_grasp is not None:  # the "ggcnn" close-view planner: its maps and peak
            x, _, _, _ = network_input(close.image.depth, cfg.camera, cfg.ggcnn)
            quality, angle, width = postprocess(model.apply(params["ggcnn"], x), cfg.ggcnn)
            info.update(quality=quality, angle=angle, width=width, pixel=close.image_grasp.pixel,
                        angle_peak=close.image_grasp.angle)
        return attempt, info

    return jax.jit(trace)


def record_rounds(cfg: Config, evaluator, params: dict, seed: int, groups: Sequence[int], rounds: int,
                  bench_rounds: int, out_dir: str, log=None) -> list[str]:
    """Plays the first ``rounds`` rounds (of the benchmark's ``bench_rounds``) of each group in
    ``groups`` (one batch) with the ``vags`` policy's ``params`` (``evaluate.vags_params``) and
    writes their pictures under ``out_dir``/objects<k>/ -> the written paths."""
    if not 1 <= rounds <= bench_rounds:
        raise ValueError(f"record_rounds: rounds must be in 1..{bench_rounds} (the benchmark's rounds), got {rounds}")
    env = evaluator.env
    B = rounds * len(groups)
    state, k_loop = evaluator.reset_groups(seed, groups, bench_rounds, rounds)
    trace = _trace_fn(cfg, env)
    step = jax.jit(lambda s, a, k: env.step_attempt(s, a, k))
    extra = cfg.benchmark.max_attempts_extra
    done = np.asarray(env.round_over(state, extra) | state.sim.error)
    records: dict[int, list[AttemptRecord]] = {i: [] for i in range(B)}
    t = 0
    while not done.all():
        k_loop, k_act, k_step = jax.random.split(k_loop, 3)
        attempt, info = trace(params, k_act, state)
        new, result = step(state, attempt, k_step if cfg.camera.noise.enabled else None)
        state = where_worlds(jnp.asarray(done), state, new)
        info, success = jax.device_get(info), np.asarray(result.success)
        pos, yaw = np.asarray(attempt.position), np.asarray(attempt.yaw)
        for i in np.flatnonzero(~done):
            direct = bool(info["direct"][i])
            gg = not direct and "quality" in info
            records[i].append(AttemptRecord(
                round_index=i % rounds, attempt_index=t, n_objects=int(groups[i // rounds]),
                color=info["color"][i], height=info["height"][i], q_grasp=info["q_grasp"][i],
                grasp=info["grasp"][i], q_max=float(info["score"][i]), threshold=float(params["threshold"]),
                direct=direct, success=bool(success[i]), grasp_world=pos[i], yaw=float(yaw[i]),
                q_view=info["q_view"][i], view=info["view"][i],
                local_depth=None if direct else info["local_depth"][i],
                ggcnn_quality=info["quality"][i] if gg else None,
                ggcnn_angle=info["angle"][i] if gg else None,
                ggcnn_width=info["width"][i] if gg else None,
                ggcnn_pixel=info["pixel"][i] if gg else None,
                ggcnn_angle_peak=float(info["angle_peak"][i]) if gg else None,
                n_rotations=cfg.net.n_rotations, half_turn=cfg.net.half_turn,
                grasp_cell=np.clip(info["cell"][i], 0, cfg.workspace.heightmap_px - 1).astype(np.float32)))
        done = done | np.asarray(env.round_over(state, extra) | state.sim.error)
        t += 1
    paths = []
    for i, recs in records.items():
        if recs:
            paths += write_round(os.path.join(out_dir, f"objects{groups[i // rounds]}"), recs)
    if log is not None:
        log(f"recorded {B} rounds ({sum(len(r) for r in records.values())} attempts) in {out_dir}")
    return paths


__all__ = ["record_rounds"]
