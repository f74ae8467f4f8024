"""Benchmark reports as files: CSV tables and (optional, matplotlib) plots.

A *report* is the dict ``vags_jax.benchmark.protocol.evaluate`` returns: ``groups_metrics`` is a list of
``summarize`` dicts, each with ``n_objects``, and ``overall`` is the pooled ``summarize`` dict.
Ratios a report leaves as None (denominator 0) become empty CSV cells and gaps in plots.

matplotlib is optional (``pip install 'vags_jax[plot]'``); the CSV writers need only the
standard library.  Plots draw on an Agg canvas (``matplotlib.figure.Figure``), never through
``pyplot``, so they neither need a display nor change the caller's matplotlib backend.
"""
from __future__ import annotations

import csv
import math
from typing import Any, Optional

# The metrics of ``evaluate.summarize``, in the order of the CSV columns.
SUMMARY_KEYS: tuple[str, ...] = (
    "rounds", "objects", "attempts", "successes", "motions", "grasp_success_rate", "clearing_rate",
    "motion_number", "picks_per_hour", "robot_seconds", "attempts_per_round", "on_object_rate",
    "viewpoint_rate", "objects_lost", "physics_errors", "buffer_overflows",
)

# Columns of a threshold sweep (``write_sweep_csv``): the sweep point, then overall metrics.
SWEEP_COLUMNS: tuple[str, ...] = (
    "kind", "quantile", "threshold", "grasp_success_rate", "clearing_rate", "motion_number",
    "viewpoint_rate", "picks_per_hour", "attempts", "successes",
)

SWEEP_KINDS = ("absolute", "quantile")

_PLOT_HINT = "plots need matplotlib: pip install 'vags_jax[plot]' (or pip install matplotlib)"


class MissingPlotExtra(ValueError):
    """matplotlib, the optional ``plot`` extra, is not installed."""


# ----------------------------------------------------------------------------- CSV


def _cell(value: Any) -> Any:
    """None -> empty cell; everything else as the csv module writes it."""
    return "" if value is None else value


def _metrics(d: Any, where: str) -> dict:
    if not isinstance(d, dict):
        raise ValueError(f"{where} must be a summarize() dict, got {type(d).__name__}")
    missing = [k for k in SUMMARY_KEYS if k not in d]
    if missing:
        raise ValueError(f"{where} lacks the summarize() keys {missing}")
    return d


def report_rows(report: dict, extra: Optional[dict] = None) -> list[dict]:
    """The rows ``write_csv`` writes: one per group (in the report's order), then ``overall``.

    Each row: ``policy``, the ``extra`` columns, ``n_objects`` (the group's size, or the
    string ``"overall"``), then ``SUMMARY_KEYS``; values as in the report (None kept).
    """
    if not isinstance(report, dict):
        raise ValueError(f"report must be the dict evaluate() returns, got {type(report).__name__}")
    for key in ("policy", "groups_metrics", "overall"):
        if key not in report:
            raise ValueError(f"report lacks {key!r} (expected the dict evaluate() returns)")
    groups = report["groups_metrics"]
    if not isinstance(groups, (list, tuple)):
        raise ValueError(f"report['groups_metrics'] must be a list of dicts, got {type(groups).__name__}")
    extra = dict(extra or {})
    clash = [k for k in extra if k in ("policy", "n_objects") + SUMMARY_KEYS]
    if clash:
        raise ValueError(f"extra columns {clash} clash with the report's own columns; rename them")
    rows = []
    for i, g in enumerate(groups):
        g = _metrics(g, f"report['groups_metrics'][{i}]")
        if "n_objects" not in g:
            raise ValueError(f"report['groups_metrics'][{i}] lacks 'n_objects'")
        rows.append({"policy": report["policy"], **extra, "n_objects": g["n_objects"],
                     **{k: g[k] for k in SUMMARY_KEYS}})
    overall = _metrics(report["overall"], "report['overall']")
    rows.append({"policy": report["policy"], **extra, "n_objects": "overall",
                 **{k: overall[k] for k in SUMMARY_KEYS}})
    return rows


def write_csv(report: dict, path: str, extra: Optional[dict] = None) -> None:
    """Writes a benchmark report as CSV: one row per group, then one ``overall`` row.

    Columns: ``policy``, the keys of ``extra`` (constant columns, e.g. ``{"threshold": 1.78}``),
    ``n_objects`` (``overall`` on the pooled row), then ``SUMMARY_KEYS`` in that order.
    A None metric is an empty cell.
    """
    rows = report_rows(report, extra)
    fields = list(rows[0].keys())
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        for row in rows:
            w.writerow({k: _cell(v) for k, v in row.items()})


def _check_sweep(rows: list[dict]) -> list[dict]:
    if not isinstance(rows, (list, tuple)) or not rows:
        raise ValueError("a threshold sweep needs a non-empty list of row dicts")
    for i, row in enumerate(rows):
        if not isinstance(row, dict):
            raise ValueError(f"sweep row {i} must be a dict, got {type(row).__name__}")
        for key in ("kind", "quantile", "threshold", "overall"):
            if key not in row:
                raise ValueError(f"sweep row {i} lacks {key!r} (keys: kind, quantile, threshold, overall, "
                                 f"groups_metrics)")
        if row["kind"] not in SWEEP_KINDS:
            raise ValueError(f"sweep row {i}: kind must be one of {SWEEP_KINDS}, got {row['kind']!r}")
        t = row["threshold"]
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not math.isfinite(t):
            raise ValueError(f"sweep row {i}: threshold must be a finite number, got {t!r}")
        if row["kind"] == "quantile" and row["quantile"] is None:
            raise ValueError(f"sweep row {i}: a 'quantile' row needs its quantile, got None")
        _metrics(row["overall"], f"sweep row {i} ['overall']")
    return list(rows)


def write_sweep_csv(rows: list[dict], path: str) -> None:
    """Writes a threshold sweep (the paper's Fig. 6) as CSV, one line per sweep point.

    ``rows``: dicts with ``kind`` ("absolute" or "quantile"), ``quantile`` (float, None for an
    absolute threshold), ``threshold`` (the decision threshold used), ``overall`` (a ``summarize``
    dict) and ``groups_metrics`` (not written).  Columns: ``SWEEP_COLUMNS``.
    """
    rows = _check_sweep(rows)
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(SWEEP_COLUMNS))
        w.writeheader()
        for row in rows:
            o = row["overall"]
            w.writerow({"kind": row["kind"], "quantile": _cell(row["quantile"]),
                        "threshold": row["threshold"],
                        **{k: _cell(o[k]) for k in SWEEP_COLUMNS[3:]}})


# ----------------------------------------------------------------------------- plots


def check_plot_available() -> None:
    """Raises ``MissingPlotExtra`` unless matplotlib can be imported (call before long work)."""
    _matplotlib()


def _matplotlib():
    """-> (Figure, FigureCanvasAgg), or MissingPlotExtra."""
    try:
        import matplotlib  # noqa: F401
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError:
        raise MissingPlotExtra(_PLOT_HINT) from None
    return Figure, FigureCanvasAgg


def _percent(value: Any) -> float:
    return float("nan") if value is None else 100.0 * float(value)


def _save(fig, canvas_cls, path: str) -> None:
    canvas_cls(fig)
    fig.savefig(path, format="png", dpi=120)


def _finish(fig, canvas_cls, path: str, axes, xlabel: str, ylabels, title: Optional[str]) -> None:
    """Labels the panels ``axes`` (percent y axes, a grid, a legend), titles ``fig`` and writes it
    to ``path``."""
    for ax, name in zip(axes, ylabels):
        ax.set_xlabel(xlabel)
        ax.set_ylabel(name)
        ax.set_ylim(-2, 102)
        ax.grid(True, alpha=0.3)
        ax.legend()
    if title:
        fig.suptitle(title)
    _save(fig, canvas_cls, path)


def plot_by_objects(reports: dict[str, dict], path: str, title: Optional[str] = None) -> None:
    """Grasp success (%) and scene clearing (%) against the number of objects (the paper's
    Fig. 7), two panels side by side, one line with markers per report.

    ``reports``: label -> report dict (``evaluate``).  Writes a PNG to ``path``.
    """
    if not isinstance(reports, dict) or not reports:
        raise ValueError("plot_by_objects needs a non-empty dict label -> report")
    series = {}
    for label, report in reports.items():
        rows = report_rows(report)[:-1]  # validates; the last row is 'overall'
        rows = sorted(rows, key=lambda r: r["n_objects"])
        series[str(label)] = ([r["n_objects"] for r in rows],
                              [_percent(r["grasp_success_rate"]) for r in rows],
                              [_percent(r["clearing_rate"]) for r in rows])
    Figure, Canvas = _matplotlib()
    fig = Figure(figsize=(10, 4), layout="constrained")
    axes = fig.subplots(1, 2)
    for label, (k, success, clearing) in series.items():
        axes[0].plot(k, success, marker="o", label=label)
        axes[1].plot(k, clearing, marker="o", label=label)
    from matplotlib.ticker import MaxNLocator

    for ax in axes:
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    _finish(fig, Canvas, path, axes, "number of objects", ("grasp success (%)", "scene clearing (%)"), title)


def plot_sweep(rows: list[dict], path: str, title: Optional[str] = None) -> None:
    """Grasp success (%) and viewpoint share (% of attempts) against the decision threshold (the
    paper's Fig. 6), two panels, one line per sweep kind; quantile thresholds are drawn at the
    threshold value they resolved to, labelled with their quantile.  Writes a PNG to ``path``."""
    rows = _check_sweep(rows)
    Figure, Canvas = _matplotlib()
    fig = Figure(figsize=(10, 4), layout="constrained")
    axes = fig.subplots(1, 2)
    for kind in SWEEP_KINDS:
        pts = sorted((r for r in rows if r["kind"] == kind), key=lambda r: r["threshold"])
        if not pts:
            continue
        t = [float(r["threshold"]) for r in pts]
        axes[0].plot(t, [_percent(r["overall"]["grasp_success_rate"]) for r in pts], marker="o", label=kind)
        axes[1].plot(t, [_percent(r["overall"]["viewpoint_rate"]) for r in pts], marker="o", label=kind)
        if kind == "quantile":  # name each point's quantile beside it
            for r, x in zip(pts, t):
                axes[0].annotate(f"q={r['quantile']:g}", (x, _percent(r["overall"]["grasp_success_rate"])),
                                 textcoords="offset points", xytext=(4, 4), fontsize=8)
    _finish(fig, Canvas, path, axes, "decision threshold (the gate's score)",
            ("grasp success (%)", "viewpoint moves (% of attempts)"), title)
