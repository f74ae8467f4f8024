#!/usr/bin/env python3
"""The issue "Viewpoints that pay"'s goals from ``eval.py`` reports: one row per policy and seed.

    python bench/viewpoint_goals.py bench/results/viewpoints/default [--policies vags vags-no-viewpoint]
    python bench/viewpoint_goals.py RUN1 --across RUN2 RUN3   # paired over each training's seeds, and over all

Reads ``DIR/seed<S>/eval_<policy>.json`` (or ``.json.gz``) and prints a Markdown table: overall success and
clearing, the same pooled over groups 6-10 (successes over attempts, cleared rounds over
rounds), motion number, viewpoint share, the viewpoint share at one object, picks per hour;
then, per seed, the first policy's gain over the second on 6-10 objects, and where the reports hold
per-round outcomes of the same scenes, the same gains paired round by round with their standard
errors (how far a seed's figure is from noise; with every seed paired, a row "all" pools their
rounds), and where the objects of those rounds were lost
(before the first attempt, by attempts after a move, by direct ones) against the rounds that ran
out of attempts: a round not cleared either lost an object or used its budget.  ``--goals``: then
the issue's goals for the first policy against the second, each with its figure per seed and
whether every seed meets it (the goal that grasps after a move be at least as good as direct
ones where the gate moves needs the gate table's states: ``bench/gate_headroom.py``).

A policy's own ablation plays the same GDNet (the report's ``gdnet``).  Where the two reports
of a seed name different GDNets (say, the ablation evaluated on another copy of the run, whose
gate table picked the other stage's), the goals against the ablation are not measured on that
seed: its figures are marked and the goal's verdict says so.
"""
from __future__ import annotations

import argparse
import glob
import gzip
import json
import os
import re
import sys


def read_report(path: str):
    """An eval.py report at ``path``, or gzipped beside it (``path``.gz, as committed); None if neither."""
    if os.path.isfile(path):
        with open(path) as f:
            return json.load(f)
    if os.path.isfile(path + ".gz"):
        with gzip.open(path + ".gz", "rt") as f:
            return json.load(f)
    return None


def pooled(report: dict, lo: int, hi: int) -> tuple[float, float]:
    """(grasp success, clearing) pooled over the groups of lo..hi objects."""
    rows = [g for g in report["groups_metrics"] if lo <= g["n_objects"] <= hi]
    succ = sum(g["successes"] for g in rows) / max(1, sum(g["attempts"] for g in rows))
    clear = sum(g["clearing_rate"] * g["rounds"] for g in rows) / max(1, sum(g["rounds"] for g in rows))
    return succ, clear


def row(report: dict) -> dict:
    o = report["overall"]
    one = [g for g in report["groups_metrics"] if g["n_objects"] == 1]
    s610, c610 = pooled(report, 6, 10)
    return {"success": o["grasp_success_rate"], "clearing": o["clearing_rate"], "success_6_10": s610,
            "clearing_6_10": c610, "motion_number": o["motion_number"], "viewpoint": o["viewpoint_rate"],
            "viewpoint_1": one[0]["viewpoint_rate"] if one else float("nan"), "picks_per_hour": o["picks_per_hour"],
            "gdnet": report.get("gdnet")}


def paired_rounds(x: dict, y: dict, lo: int, hi: int):
    """Report ``x`` against report ``y`` round by round over the groups of lo..hi objects, on the
    same scenes: (grasp success x - y, its standard error, clearing x - y, its standard error,
    rounds), or None where a report lacks per-round outcomes, the scenes differ (the reports'
    ``scenes`` digests) or a group's round counts differ.  Clearing is the mean of the paired
    per-round differences; success is a ratio (successes / attempts), so each round enters
    through its deviation from the pooled ratio, scaled by the mean attempts per round (the
    delta method), and the standard error is that of the mean paired deviation."""
    return paired_rounds_pooled([(x, y)], lo, hi)


def paired_rounds_pooled(pairs: list, lo: int, hi: int):
    """``paired_rounds`` over the rounds of several (x, y) report pairs at once (say, every seed's):
    the same figures, pooled; None where any pair cannot be paired."""
    import numpy as np

    cols = {"x": [], "y": []}
    for x, y in pairs:
        if "outcomes" not in x or "outcomes" not in y or x.get("scenes") != y.get("scenes"):
            return None
        for n in range(lo, hi + 1):
            ox, oy = x["outcomes"].get(str(n)), y["outcomes"].get(str(n))
            if ox is None or oy is None:
                continue
            if len(ox["attempts"]) != len(oy["attempts"]):
                return None
            for side, o in (("x", ox), ("y", oy)):
                cols[side].append(np.stack([np.asarray(o[k], float) for k in ("attempts", "successes", "n_objects")]))
    if not cols["x"]:
        return None
    (ax, sx, nx), (ay, sy, ny) = np.concatenate(cols["x"], 1), np.concatenate(cols["y"], 1)
    rounds = ax.size
    if rounds < 2:
        return None
    px, py = sx.sum() / ax.sum(), sy.sum() / ay.sum()
    d = (sx - px * ax) / ax.mean() - (sy - py * ay) / ay.mean()
    c = (sx >= nx).astype(float) - (sy >= ny).astype(float)
    se = lambda v: float(v.std(ddof=1) / np.sqrt(rounds))  # noqa: E731
    return float(px - py), se(d), float(c.mean()), se(c), rounds


LOSS_FIELDS = ("n_objects", "attempts", "successes", "remaining", "viewpoints", "lost_after_move", "lost_at_start")


def losses(report: dict, lo: int, hi: int):
    """Where the objects of the groups of lo..hi objects were lost (left the table without a
    grasp): a dict of counts over their rounds -> lost, at_start (gone before the first attempt),
    after_move (knocked off by attempts made after a camera move), direct (by the other
    attempts), attempts, moved (attempts after a move), rounds, losing (rounds that lost one),
    out (rounds that ended with objects left and their attempt budget of 2k + extra used),
    cleared; or None where the report lacks the per-round outcomes.  A round is cleared when
    it neither lost an object nor ran out of attempts, so ``losing`` and ``out`` are why a
    round is not cleared (both can hold)."""
    import numpy as np

    m = re.fullmatch(r"2 \* objects \+ (\d+)", str(report.get("max_attempts", "")))
    groups = [o for n, o in (report.get("outcomes") or {}).items() if lo <= int(n) <= hi]
    if not groups or m is None or any(f not in o for o in groups for f in LOSS_FIELDS):
        return None
    n, att, succ, left, moved, after, start = (np.concatenate([np.asarray(o[f], int) for o in groups])
                                               for f in LOSS_FIELDS)
    lost = n - succ - left
    return {"lost": int(lost.sum()), "at_start": int(start.sum()), "after_move": int(after.sum()),
            "direct": int((lost - start - after).sum()), "attempts": int(att.sum()), "moved": int(moved.sum()),
            "rounds": int(n.size), "losing": int((lost > 0).sum()),
            "out": int(((left > 0) & (att >= 2 * n + int(m.group(1)))).sum()), "cleared": int((succ >= n).sum())}


def losses_table(reports: dict, policies: list, seeds: list, lo: int = 6, hi: int = 10) -> list:
    """Markdown lines: ``losses`` pooled over the seeds, one row per policy whose reports all
    hold per-round outcomes; [] when none does."""
    lines = []
    for pol in policies:
        parts = [losses(reports[pol, s], lo, hi) for s in seeds if (pol, s) in reports]
        if not parts or any(x is None for x in parts):
            continue
        t = {k: sum(x[k] for x in parts) for k in parts[0]}
        per = lambda k, d: f"{t[k]} ({100 * t[k] / d:.1f} %)" if d else "-"  # noqa: E731
        lines.append(f"| {pol} | {t['attempts']} | {t['moved']} | {t['lost']} | {t['at_start']} | "
                     f"{per('after_move', t['moved'])} | {per('direct', t['attempts'] - t['moved'])} | "
                     f"{t['losing']} of {t['rounds']} | {t['out']} | {t['cleared']} of {t['rounds']} |")
    if not lines:
        return []
    return [f"\nWhere the objects of the {lo}-{hi} piles were lost ({len(seeds)} seed{'s' if len(seeds) > 1 else ''} "
            "pooled):\n",
            "| policy | attempts | after a move | objects lost | gone at start | lost by attempts after a move "
            "(per such attempt) | lost by direct attempts (per attempt) | rounds that lost one | rounds out of "
            "attempts | cleared |",
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"] + lines


# Issue 23's goals: (name, figure of a (VAGS row, ablation row) pair, "min" / "max" / "below", bound,
# how the figure prints).  "min": at least the bound; "max": at most; "below": strictly below.
# The goals named in AGAINST_ABLATION read the ablation's row.
GOALS = (
    ("success at least 85 %", lambda v, a: 100 * v["success"], "min", 85.0, "{:.1f}"),
    ("6-10 success at least 5 points above the ablation",
     lambda v, a: 100 * (v["success_6_10"] - a["success_6_10"]), "min", 5.0, "{:+.1f}"),
    ("6-10 clearing no worse than the ablation's",
     lambda v, a: 100 * (v["clearing_6_10"] - a["clearing_6_10"]), "min", 0.0, "{:+.1f}"),
    ("motion number below 1.35", lambda v, a: v["motion_number"], "below", 1.35, "{:.2f}"),
    ("at one object, moves on at most 10 % of attempts", lambda v, a: 100 * v["viewpoint_1"], "max", 10.0, "{:.1f}"),
)


AGAINST_ABLATION = ("6-10 success at least 5 points above the ablation", "6-10 clearing no worse than the ablation's")


def gate_lost_table(top: str, looks) -> list:
    """Markdown lines: the objects knocked off on the same states of every gate table found as
    ``TOP/<look>_look/<run>/gate.json`` (its ``lost``: all states and the moving bins' states,
    direct grasp against the grasp after a move, per 100 states), for the tables whose direct
    grasp GDNet planned ("q", "q_mean"), then the range and mean of the moving bins' difference."""
    lines = ["| table | direct score | states | direct % | moved % | moved - direct | moving bins: states | direct % "
             "| moved % | moved - direct |", "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    diffs = []
    for look in looks:
        folder = os.path.join(top, f"{look}_look")
        for sub in sorted(os.listdir(folder)):
            path = os.path.join(folder, sub, "gate.json")
            if not os.path.isfile(path):
                continue
            with open(path) as f:
                g = json.load(f)
            if "lost" not in g or g.get("direct_score") not in ("q", "q_mean"):
                continue
            a, m = g["lost"]["all"], g["lost"]["moved_bins"]
            diffs.append(100 * m["difference"])
            lines.append(f"| {look}/{sub} | {g['direct_score']} | {a['states']} | {100 * a['direct']:.1f} | "
                         f"{100 * a['moved']:.1f} | {100 * a['difference']:+.1f} ± {100 * a['se']:.1f} | {m['states']} | "
                         f"{100 * m['direct']:.1f} | {100 * m['moved']:.1f} | {100 * m['difference']:+.1f} ± "
                         f"{100 * m['se']:.1f} |")
    if diffs:
        lines += ["", f"{len(diffs)} tables; moving bins, moved - direct: {min(diffs):+.1f} to {max(diffs):+.1f}, "
                      f"mean {sum(diffs) / len(diffs):+.2f} points"]
    return lines


def other_gdnet(x: dict, y: dict) -> bool:
    """True when two rows name different GDNets (rows of reports without the key never differ)."""
    return x.get("gdnet") is not None and y.get("gdnet") is not None and x["gdnet"] != y["gdnet"]


def goal_met(kind: str, value: float, bound: float) -> bool:
    if kind == "min":
        return value >= bound - 1e-9
    if kind == "max":
        return value <= bound + 1e-9
    return value < bound


def checks_met(run: str, policy: str, ablation: str, seeds) -> tuple[int, int] | None:
    """(goal checks met, checks made) of GOALS for ``policy`` against ``ablation`` over ``seeds``,
    from ``RUN/seed<S>/eval_<policy>.json``: one check per goal and seed; None where a report is
    missing."""
    met = total = 0
    for s in seeds:
        x = read_report(os.path.join(run, f"seed{s}", f"eval_{policy}.json"))
        y = read_report(os.path.join(run, f"seed{s}", f"eval_{ablation}.json"))
        if x is None or y is None:
            return None
        a, b = row(x), row(y)
        for _, figure, kind, bound, _ in GOALS:
            total += 1
            met += goal_met(kind, figure(a, b), bound)
    return met, total


def goals_table(rows: dict, a: str, b: str, seeds: list) -> list:
    """Markdown lines: each goal's figure per seed (policy a against policy b) and whether
    every seed with both reports meets it; then lines naming the goals missed, and those not
    measured because a seed's ablation played another GDNet than the policy."""
    pairs = [s for s in seeds if (a, s) in rows and (b, s) in rows]
    foreign = [s for s in pairs if other_gdnet(rows[a, s], rows[b, s])]
    lines = [f"| goal ({a} against {b}) | " + " | ".join(f"seed {s}" for s in pairs) + " | met on every seed |",
             "|---|" + "---:|" * len(pairs) + "---|"]
    missed, unmeasured = [], []
    for name, figure, kind, bound, fmt in GOALS:
        values = [figure(rows[a, s], rows[b, s]) for s in pairs]
        mine = [not (name in AGAINST_ABLATION and s in foreign) for s in pairs]
        cells = [fmt.format(v) + (" (other GDNet)" if not m else "" if goal_met(kind, v, bound) else " (missed)")
                 for v, m in zip(values, mine)]
        ok = all(goal_met(kind, v, bound) for v, m in zip(values, mine) if m)
        verdict = "yes" if ok and all(mine) else "no" if not ok else "not measured"
        if not ok:
            missed.append(name)
        elif not all(mine):
            unmeasured.append(name)
        lines.append(f"| {name} | " + " | ".join(cells) + f" | {verdict} |")
    by_pair = {}
    for s in foreign:
        by_pair.setdefault((rows[a, s]["gdnet"], rows[b, s]["gdnet"]), []).append(str(s))
    for (ga, gb), ss in by_pair.items():
        lines.append(f"\nseed{'s' if len(ss) > 1 else ''} {', '.join(ss)}: {a} played GDNet {ga!r}, {b} {gb!r}: "
                     f"not its own ablation (evaluate {b} on the run {a} played)")
    if unmeasured:
        lines.append("\nnot measured on every seed: " + "; ".join(unmeasured))
    lines.append("\nall these goals met on every seed" if not missed and not unmeasured else
                 "\nmissed: " + "; ".join(missed) if missed else "\nno goal measured is missed")
    return lines


def seeds_in(folder: str) -> list:
    """The seeds S of ``FOLDER/seed<S>/``, in order."""
    return sorted(int(re.sub(r"\D", "", os.path.basename(d))) for d in glob.glob(os.path.join(folder, "seed*")))


def across_table(folders: list, a: str, b: str) -> list:
    """Markdown lines: per folder (one training each), policy a against policy b paired round by
    round over all its seeds' rounds (6-10 success, 6-10 clearing, clearing over every group),
    then a row "all" pooling every folder's rounds; a folder whose reports cannot all be paired
    is named and left out of "all"."""
    lines = [f"| training | paired 6-10 rounds | 6-10 success: {a} - {b} | 6-10 clearing | all rounds: clearing |",
             "|---|---:|---:|---:|---:|"]
    fmt = lambda v: f"{100 * v[0]:+.1f} ± {100 * v[1]:.1f}"  # noqa: E731
    clear = lambda v: f"{100 * v[2]:+.1f} ± {100 * v[3]:.1f}"  # noqa: E731
    pooled = []
    for folder in folders:
        pairs = [(read_report(os.path.join(folder, f"seed{s}", f"eval_{a}.json")),
                  read_report(os.path.join(folder, f"seed{s}", f"eval_{b}.json"))) for s in seeds_in(folder)]
        pairs = [(x, y) for x, y in pairs if x is not None and y is not None]
        mid, every = (paired_rounds_pooled(pairs, 6, 10), paired_rounds_pooled(pairs, 1, 10)) if pairs else (None, None)
        if mid is None or every is None:
            lines.append(f"| {folder} | not paired (missing reports, no per-round outcomes or other scenes) | | | |")
            continue
        pooled += pairs
        lines.append(f"| {folder} | {mid[4]} | {fmt(mid)} | {clear(mid)} | {clear(every)} |")
    if len(pooled) and len(folders) > 1:
        mid, every = paired_rounds_pooled(pooled, 6, 10), paired_rounds_pooled(pooled, 1, 10)
        lines.append(f"| all | {mid[4]} | {fmt(mid)} | {clear(mid)} | {clear(every)} |")
    lines.append("(paired round by round on the same scenes, every seed of a training pooled; ± one standard error)")
    return lines


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("dir", help="folder with seed<S>/eval_<policy>.json")
    p.add_argument("--across", nargs="+", default=None, metavar="DIR",
                   help="more trainings' folders: print only the first two policies paired over each folder's "
                        "rounds and over all of them (DIR first)")
    p.add_argument("--policies", nargs="+", default=["vags", "vags-no-viewpoint"])
    p.add_argument("--goals", action="store_true", help="also the issue's goals for the first policy against the "
                   "second, per seed")
    args = p.parse_args(argv)
    if args.across is not None:
        if len(args.policies) < 2:
            print("--across compares two policies: give --policies VAGS ABLATION", file=sys.stderr)
            return 2
        print("\n".join(across_table([args.dir] + args.across, *args.policies[:2])))
        return 0
    seeds = seeds_in(args.dir)
    rows, reports = {}, {}
    for pol in args.policies:
        for s in seeds:
            report = read_report(os.path.join(args.dir, f"seed{s}", f"eval_{pol}.json"))
            if report is not None:
                rows[pol, s], reports[pol, s] = row(report), report
    if not rows:
        print(f"no reports under {args.dir}/seed*/ for {args.policies}", file=sys.stderr)
        return 2
    pct = lambda v: f"{100 * v:.1f}"  # noqa: E731
    print("| policy | seed | success | clearing | 6-10 success | 6-10 clearing | motion number | viewpoint % "
          "| at 1 object: viewpoint % | picks/h |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for (pol, s), r in rows.items():
        print(f"| {pol} | {s} | {pct(r['success'])} | {pct(r['clearing'])} | {pct(r['success_6_10'])} | "
              f"{pct(r['clearing_6_10'])} | {r['motion_number']:.2f} | {pct(r['viewpoint'])} | "
              f"{pct(r['viewpoint_1'])} | {r['picks_per_hour']:.0f} |")
    a, b = args.policies[:2] if len(args.policies) > 1 else (args.policies[0], None)
    if b is not None:
        print(f"\n| seed | 6-10 success: {a} - {b} | 6-10 clearing | overall clearing |")
        print("|---:|---:|---:|---:|")
        for s in seeds:
            if (a, s) in rows and (b, s) in rows:
                x, y = rows[a, s], rows[b, s]
                mark = " (other GDNet)" if other_gdnet(x, y) else ""
                print(f"| {s}{mark} | {100 * (x['success_6_10'] - y['success_6_10']):+.1f} | "
                      f"{100 * (x['clearing_6_10'] - y['clearing_6_10']):+.1f} | {100 * (x['clearing'] - y['clearing']):+.1f} |")
        paired = {s: paired_rounds(reports[a, s], reports[b, s], 6, 10) for s in seeds
                  if (a, s) in reports and (b, s) in reports}
        if any(v is not None for v in paired.values()):
            print(f"\n| seed | rounds | 6-10 success: {a} - {b} | 6-10 clearing |")
            print("|---:|---:|---:|---:|")
            pooled = (paired_rounds_pooled([(reports[a, s], reports[b, s]) for s in paired], 6, 10)
                      if len(paired) > 1 else None)
            for s, v in list(paired.items()) + ([("all", pooled)] if pooled is not None else []):
                print(f"| {s} | not paired (no per-round outcomes or other scenes) | | |" if v is None else
                      f"| {s} | {v[4]} | {100 * v[0]:+.1f} ± {100 * v[1]:.1f} | {100 * v[2]:+.1f} ± {100 * v[3]:.1f} |")
            print("(paired round by round on the same scenes; ± one standard error of the difference; \"all\": "
                  "every seed's rounds pooled)")
        lost = losses_table(reports, args.policies, seeds)
        if lost:
            print("\n".join(lost))
        if args.goals:
            print()
            print("\n".join(goals_table(rows, a, b, seeds)))
    elif args.goals:
        print("--goals compares two policies: give --policies VAGS ABLATION", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
