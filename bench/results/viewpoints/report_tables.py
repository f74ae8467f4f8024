"""Reads the gzipped (or plain) JSON reports of eval.py kept under bench/results/viewpoints/ and
prints the rows of bench/RESULTS.md's viewpoint tables; imported by each run's tables.py."""
import gzip
import json
import os


def report(path):
    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rt") as f:
        return json.load(f)


def find(folder, name):
    """The report ``name`` (e.g. "eval_vags") in ``folder``, as NAME.json or NAME.json.gz."""
    for p in (os.path.join(folder, name + ".json"), os.path.join(folder, name + ".json.gz")):
        if os.path.isfile(p):
            return report(p)
    raise FileNotFoundError(os.path.join(folder, name))


def row(d):
    """overall success, 6-10 success, 6-10 clearing, motion number, moves %, moves at 1 object %, picks/h"""
    o, groups = d["overall"], d["groups_metrics"]
    big = [g for g in groups if g["n_objects"] >= 6]
    s610 = sum(g["successes"] for g in big) / sum(g["attempts"] for g in big)
    c610 = sum(g["clearing_rate"] * g["rounds"] for g in big) / sum(g["rounds"] for g in big)
    one = [g for g in groups if g["n_objects"] == 1][0]
    return (100 * o["grasp_success_rate"], 100 * s610, 100 * c610, o["motion_number"], 100 * o["viewpoint_rate"],
            100 * one["viewpoint_rate"], o["picks_per_hour"])


def table(title, cases):
    """Prints one markdown table; cases: (seed, networks, policy, report) tuples."""
    print(f"\n{title}\n")
    print("| seed | networks | policy | success % | 6-10 success % | 6-10 clearing % | motion number | moves % | "
          "moves at 1 object % | picks/h |")
    print("|---:|---|---|---:|---:|---:|---:|---:|---:|---:|")
    for seed, nets, policy, d in cases:
        r = row(d)
        print(f"| {seed} | {nets} | {policy} | {r[0]:.1f} | {r[1]:.1f} | {r[2]:.1f} | {r[3]:.3f} | {r[4]:.1f} | "
              f"{r[5]:.1f} | {r[6]:.0f} |")


def differences(title, columns, rows):
    """Prints a markdown table of differences in points: columns (names after "seed"), rows
    (seed, value, ...) tuples, each value signed to one decimal."""
    print(f"\n{title}\n")
    print("| seed | " + " | ".join(columns) + " |")
    print("|---:|" + "---:|" * len(columns))
    for r in rows:
        print("| " + " | ".join([str(r[0])] + [f"{x:+.1f}" for x in r[1:]]) + " |")


def branches_table(label, rows):
    """Prints the by-branch table: label names the second column ("networks", "scenes"); rows
    (seed, label value, VAGS direct, after a move, first attempts, ablation first attempts)
    tuples of fractions."""
    print(f"\n| seed | {label} | VAGS: direct grasps % | VAGS: grasps after a move % | VAGS: first attempts % | "
          "ablation: first attempts % |\n|---:|---|---:|---:|---:|---:|")
    for s, name, d, m, f, fn in rows:
        print(f"| {s} | {name} | {100 * d:.1f} | {100 * m:.1f} | {100 * f:.1f} | {100 * fn:.1f} |")


def lost_row(d):
    """6-10 objects: attempts, objects lost, lost per attempt over all attempts, over direct
    attempts (the losses of grasps after a move taken out), and per move."""
    a = lost = moves = lost_moved = 0
    for k in range(6, 11):
        o = d["outcomes"][str(k)]
        for n, att, s, rem, v, lm in zip(o["n_objects"], o["attempts"], o["successes"], o["remaining"],
                                          o["viewpoints"], o["lost_after_move"]):
            a, lost, moves, lost_moved = a + att, lost + n - s - rem, moves + v, lost_moved + lm
    return a, lost, lost / a, (lost - lost_moved) / (a - moves), (lost_moved / moves if moves else float("nan"))


def moved_share(d):
    """Percent of the attempts on 6-10 objects that moved the camera first."""
    big = [g for g in d["groups_metrics"] if g["n_objects"] >= 6]
    return 100 * sum(g["viewpoint_rate"] * g["attempts"] for g in big) / sum(g["attempts"] for g in big)


def margin_fits(up, evals):
    """Every VAGS evaluation of ``evals`` ((look, its VAGS folder, its ablation's folder) under
    ``up``, seeds 11-13) against the ablation of its own training and seed: 6-10 margin, moves,
    motion number; then two least-squares lines."""
    import numpy as np
    rows = []
    print("\n| look | VAGS | seed | 6-10 margin | 6-10 attempts moved % | motion number |\n|---|---|---:|---:|---:|---:|")
    for look, sub, ablation in evals:
        for s in (11, 12, 13):
            va = find(os.path.join(up, look, sub, f"seed{s}"), "eval_vags")
            nv = find(os.path.join(up, look, ablation, f"seed{s}"), "eval_vags-no-viewpoint")
            r = (row(va)[1] - row(nv)[1], moved_share(va), row(va)[3])
            rows.append(r)
            print(f"| {look} | {sub or 'run'} | {s} | {r[0]:+.1f} | {r[1]:.1f} | {r[2]:.3f} |")
    m, moved, mn = np.array(rows).T
    a, b = np.polyfit(moved, m, 1)
    c, d = np.polyfit(mn, m, 1)
    print(f"\nmargin = {a:.3f} x moved % {b:+.2f};  margin = {c:.2f} x motion number {d:+.2f}, "
          f"{np.polyval([c, d], 1.35):+.2f} at 1.35")


def lost_table(losses):
    """Prints the table of objects that left the table on 6-10 objects; losses: (seed, networks,
    policy, ``lost_row``) tuples."""
    print("\nObjects that left the table without a grasp, 6-10 objects (250 rounds)\n")
    print("| seed | networks | policy | attempts | objects lost | per attempt | per direct attempt | per move |")
    print("|---:|---|---|---:|---:|---:|---:|---:|")
    for s, nets, policy, (a, lost, per, direct, moved) in losses:
        print(f"| {s} | {nets} | {policy} | {a} | {lost} | {per:.3f} | {direct:.3f} | "
              + ("" if moved != moved else f"{moved:.3f}") + " |")


def vags_against_ablation(here, runs, evals):
    """Prints a look's tables for ``runs`` ((folder under ``here``, networks label) tuples, each
    with seed<S>/eval_vags and eval_vags-no-viewpoint, seeds 11-13): both policies, VAGS's
    margins, its branches, the objects lost on 6-10 objects, and the margin fit over ``evals``
    (``margin_fits``, looks beside ``here``)."""
    cases, gains, branches, losses = [], [], [], []
    for sub, nets in runs:
        for s in (11, 12, 13):
            nv = find(os.path.join(here, sub, f"seed{s}"), "eval_vags-no-viewpoint")
            va = find(os.path.join(here, sub, f"seed{s}"), "eval_vags")
            cases += [(s, nets, "`--no-viewpoint`", nv), (s, nets, "VAGS", va)]
            rn, rv = row(nv), row(va)
            gains.append((f"{s}, {nets}", rv[0] - rn[0], rv[1] - rn[1], rv[2] - rn[2]))
            o = va["overall"]
            branches.append((s, nets, o["success_direct"], o["success_after_move"], o["first_attempt_success"],
                             nv["overall"]["first_attempt_success"]))
            losses += [(s, nets, "`--no-viewpoint`", lost_row(nv)), (s, nets, "VAGS", lost_row(va))]
    table("The default scenes, groups 1-10 x 50 rounds", cases)
    differences("Points, VAGS − ablation", ["success", "6-10 success", "6-10 clearing"], gains)
    branches_table("networks", branches)
    lost_table(losses)
    margin_fits(os.path.dirname(here), evals)
