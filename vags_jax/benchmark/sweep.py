"""Threshold sweeps of the ``vags`` policy (paper Fig. 6): the benchmark at each absolute
threshold, and at quantiles of the gate's scores seen at the main run's decisions
(``policies.decision.gate_score``: GDNet's largest Q for the "q" gate)."""
from __future__ import annotations

import dataclasses

import jax.numpy as jnp
import numpy as np

from vags_jax.benchmark import metrics as M
from vags_jax.benchmark import protocol as E


def run_sweep(cfg, ev, pol, report, sweep_abs, sweep_q, groups, rounds, seed, time_model, log) -> list[dict]:
    """The benchmark at each threshold (absolute values, then quantiles of the gate's scores
    seen at the main run's decisions) -> rows for reports.write_sweep_csv."""
    scores = np.concatenate([np.asarray(o["scores"], np.float64).ravel() for o in report["outcomes"].values()])
    scores = scores[np.isfinite(scores)]
    points = [("absolute", None, t) for t in sweep_abs]
    if sweep_q:
        if scores.size == 0:
            raise ValueError("the main run recorded no decision values to take quantiles of")
        points += [("quantile", q, float(np.quantile(scores, q))) for q in sweep_q]
    rows = []
    for kind, q, thr in points:
        p = dataclasses.replace(pol, params={**pol.params, "threshold": jnp.asarray(thr, jnp.float32)})
        r = E.evaluate(cfg, p, groups, rounds, seed, time_model, ev)
        o = r["overall"]
        log(f"sweep {kind} {'' if q is None else f'q={q:g} '}threshold {thr:.4f}: success "
            f"{M._pct(o['grasp_success_rate'])} %, clearing {M._pct(o['clearing_rate'])} %, viewpoint "
            f"{M._pct(o['viewpoint_rate'])} %")
        rows.append({"kind": kind, "quantile": q, "threshold": thr, "overall": o, "groups_metrics": r["groups_metrics"]})
    return rows


def format_sweep(rows: list[dict]) -> str:
    """Markdown table of a threshold sweep."""

    out = ["| sweep | quantile | threshold | grasp success % | clearing % | motion number | viewpoint % | picks/hour |",
           "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        o = r["overall"]
        out.append(f"| {r['kind']} | {'-' if r['quantile'] is None else format(r['quantile'], 'g')} | "
                   f"{r['threshold']:.4f} | {M._pct(o['grasp_success_rate'])} | {M._pct(o['clearing_rate'])} | "
                   f"{M._num(o['motion_number'])} | {M._pct(o['viewpoint_rate'])} | {M._num(o['picks_per_hour'], '{:.0f}')} |")
    return "\n".join(out)
