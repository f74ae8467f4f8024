"""The paper's comparison (Table 1, Fig. 7): several methods on the same scenes, one table.

``eval.py --compare A B ...`` (``requests.prepare_compare`` checks every item first): each item
is a policy name (of ``policies.catalog.POLICIES``, with ``--run``'s networks where it needs
any), a run directory (its default policy), ``RUN:policy``, or a report ``.json`` that eval.py
wrote earlier (it must have the same seed, groups and rounds).  Every method plays in ONE
``Evaluator`` (one environment, one config), so every method plays the same scenes with the same
seed; each report records the ``scenes`` digest of the scenes it played, and ``check_same_scenes``
refuses a table whose methods did not all play the same ones.

``table1`` prints one row per method: rounds, attempts, grasp success and scene clearing with
their 95 % Wilson intervals (on the pooled attempts and rounds), motion number and picks per
hour.  ``write_comparison`` writes the JSON (every method's whole report) and a CSV with one
row per method and group plus an ``overall`` row per method.
"""
from __future__ import annotations

import csv
import json
import os
from typing import Callable, Optional

import jax
import numpy as np

from vags_jax.benchmark import protocol as E
from vags_jax.benchmark import reports
from vags_jax.benchmark.metrics import wilson_interval

CSV_COLUMNS = ("method", "policy", "n_objects", "rounds", "attempts", "successes", "grasp_success_rate",
               "success_low", "success_high", "cleared", "clearing_rate", "clearing_low", "clearing_high",
               "motions", "motion_number", "picks_per_hour", "robot_seconds", "objects_lost", "physics_errors")


def _cleared(m: dict) -> int:
    return int(round((m["clearing_rate"] or 0.0) * m["rounds"]))


def with_intervals(m: dict) -> dict:
    """A ``summarize`` dict with the 95 % Wilson intervals of its two rates added:
    success_low / success_high (successes of attempts), clearing_low / clearing_high (cleared
    rounds of rounds), None where there is no attempt / round; and ``cleared``."""
    out = dict(m)
    s = wilson_interval(m["successes"], m["attempts"])
    c = wilson_interval(_cleared(m), m["rounds"])
    out["success_low"], out["success_high"] = s if s else (None, None)
    out["clearing_low"], out["clearing_high"] = c if c else (None, None)
    out["cleared"] = _cleared(m)
    return out


def _pct_ci(rate, low, high) -> str:
    if rate is None:
        return "-"
    return f"{100 * rate:.1f} [{100 * low:.1f}, {100 * high:.1f}]"


def table1(reports: dict) -> str:
    """Markdown Table 1: one row per method (label -> ``evaluate`` report), its ``overall``
    figures; rates in % with their 95 % Wilson intervals in brackets."""
    head = ("| method | rounds | attempts | grasp success % [95 % CI] | clearing % [95 % CI] | motion number "
            "| picks/hour |")
    rows = [head, "|---|---:|---:|---:|---:|---:|---:|"]
    for label, rep in reports.items():
        m = with_intervals(rep["overall"])
        mn = "-" if m["motion_number"] is None else f"{m['motion_number']:.2f}"
        pph = "-" if m["picks_per_hour"] is None else f"{m['picks_per_hour']:.0f}"
        rows.append(f"| {label} | {m['rounds']} | {m['attempts']} | "
                    f"{_pct_ci(m['grasp_success_rate'], m['success_low'], m['success_high'])} | "
                    f"{_pct_ci(m['clearing_rate'], m['clearing_low'], m['clearing_high'])} | {mn} | {pph} |")
    return "\n".join(rows)


def comparison_rows(reports: dict) -> list[dict]:
    """The CSV rows: per method, one per group (in the report's order), then ``overall``."""
    rows = []
    for label, rep in reports.items():
        for m in list(rep["groups_metrics"]) + [dict(rep["overall"], n_objects="overall")]:
            m = with_intervals(m)
            rows.append({"method": label, "policy": rep["policy"], **{k: m.get(k) for k in CSV_COLUMNS[2:]}})
    return rows


# What makes two reports' scenes the same besides the draws the digest hashes: the layout and
# settling (``scene``), the workspace, and what the global camera sees (pose, optics, sensor).
SCENE_SETTINGS = ("scene", "workspace", "camera.width", "camera.height", "camera.fx", "camera.fy", "camera.cx",
                  "camera.cy", "camera.global_position", "camera.global_target", "camera.noise")


_UNRECORDED = object()


def _setting(report: dict, path: str):
    """The value at ``path`` of the report's recorded config (None is a value, e.g. ``camera.cx``),
    or ``_UNRECORDED``."""
    value = report.get("config")
    for part in path.split("."):
        if not isinstance(value, dict) or part not in value:
            return _UNRECORDED
        value = value[part]
    return value


def _first_difference(path: str, a, b):
    """(dotted path, a's value, b's value) of the first leaf where ``a`` and ``b`` differ."""
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if a.get(k) != b.get(k):
                return _first_difference(f"{path}.{k}", a.get(k), b.get(k))
    return path, a, b


def check_same_scenes(reports: dict, digests: bool = True) -> None:
    """ValueError unless every report played the same seed, groups, rounds, scene settings
    (``SCENE_SETTINGS`` of the recorded configs, where both have them) and (where recorded, and
    unless ``digests`` is False) the same scene draws."""
    if not reports:
        return
    first_label, first = next(iter(reports.items()))
    for label, rep in reports.items():
        for key in ("seed", "groups", "rounds"):
            if rep.get(key) != first.get(key):
                raise ValueError(f"--compare: {label} played {key} {rep.get(key)}, {first_label} {first.get(key)}: "
                                 f"a table needs every method on the same scenes (same --seed, --groups, --rounds)")
        for path in SCENE_SETTINGS:
            a, b = _setting(rep, path), _setting(first, path)
            if a is not _UNRECORDED and b is not _UNRECORDED and a != b:
                where, va, vb = _first_difference(path, a, b)
                raise ValueError(f"--compare: {label} and {first_label} played scenes of different settings "
                                 f"({where}: {va} and {vb}): put reports of one scene variant (--scenes) in a table")
        a, b = rep.get("scenes"), first.get("scenes")
        if digests and a is not None and b is not None and a != b:
            raise ValueError(f"--compare: {label} played other scenes than {first_label} (scene digests {a} and "
                             f"{b}): their configs' scene or object settings differ")


def write_comparison(reports: dict, path: str, meta: Optional[dict] = None) -> str:
    """Writes the comparison as JSON at ``path`` ({"methods": [{"label", "report"}], "table1":
    rows of the overall figures with intervals, and ``meta``}) and as CSV beside it -> the CSV's
    path."""
    data = dict(meta or {})
    data["methods"] = [{"label": k, "report": v} for k, v in reports.items()]
    data["table1"] = [{"method": k, **with_intervals(v["overall"])} for k, v in reports.items()]
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, "w") as f:
        json.dump(data, f, indent=1)
    csv_path = os.path.splitext(path)[0] + ".csv"
    with open(csv_path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(CSV_COLUMNS))
        w.writeheader()
        for row in comparison_rows(reports):
            w.writerow({k: "" if v is None else v for k, v in row.items()})
    return csv_path



def publish(results: dict, out: Optional[str], plot: Optional[str], meta: dict, log: Callable,
            digests: bool = True) -> None:
    """Table 1 of ``results`` ({label: report}) after ``check_same_scenes`` (its ValueError
    comes before anything is printed or written): printed to stdout, as JSON + CSV at ``out``
    (``meta`` added to the JSON) and as Fig. 7 at ``plot`` (PNG), each optional."""
    check_same_scenes(results, digests)
    print(table1(results))
    if out:
        csv_path = write_comparison(results, out, meta)
        log(f"wrote {out} and {csv_path}")
    if plot:
        reports.plot_by_objects(results, plot)
        log(f"wrote {plot}")


def play_methods(plan, policy_of: Callable, log: Callable) -> dict:
    """Every method of a checked comparison (``requests.prepare_compare``) played in ONE
    ``Evaluator`` (the same scenes and seed for all), or taken from its saved report ->
    {label: report}.  ``policy_of(method_plan) -> Policy``."""
    ev, results = None, {}
    for label, mplan, saved in plan.methods:
        if saved is not None:
            results[label] = saved
            continue
        log(f"evaluating {label}" + (f" ({mplan.run})" if mplan.run else "") + f": groups {plan.groups}, "
            f"{plan.rounds} rounds each, seed {plan.seed}, devices={jax.devices()}")
        ev = ev if ev is not None else E.Evaluator(plan.cfg)
        pol = policy_of(mplan)
        report = E.evaluate(plan.cfg, pol, plan.groups, plan.rounds, plan.seed, plan.time_model, ev, log=log)
        report["run"] = mplan.run
        if mplan.policy == "vags":
            report["threshold"] = float(np.asarray(pol.params["threshold"]))
        results[label] = report
    return results


__all__ = ["CSV_COLUMNS", "with_intervals", "table1", "comparison_rows", "check_same_scenes", "write_comparison",
           "publish", "play_methods"]
