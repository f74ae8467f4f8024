"""Prints the tables of bench/RESULTS.md, "Viewpoints that pay, twenty-third look": the `gpu`
preset trained twice on one H200 (``fallback``: after the compile-ahead threads crashed, with
--compile-ahead off; ``warm``: the reverted tree, compile cache warm), VAGS and ``--no-viewpoint``
on the default scenes, seeds 11-13, for each training; on 6-10 objects, where objects left the
table; the 6-10 margin against the moves and the motion number over the twentieth to
twenty-third looks; and the Fig. 6 sweep's rows.
Run from anywhere: python bench/results/viewpoints/default/twentythird_look/tables.py"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(os.path.dirname(HERE)))
from report_tables import branches_table, differences, find, row, table  # noqa: E402

RUNS = (("fallback", "run g54f"), ("warm", "run g55w"))


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


def margin_fits():
    """Every VAGS evaluation of the twentieth to twenty-third looks against the ablation of its
    own training and seed: 6-10 margin, moves, motion number; then two least-squares lines."""
    import numpy as np
    up = os.path.dirname(HERE)
    evals = [("twentieth_look", "", "")] + [("twentyfirst_look", v, "") for v in ("", "cap130", "bins16_cap130")] \
        + [("twentysecond_look", r, r) for r in ("cold", "warm")] \
        + [("twentythird_look", r, r) for r in ("fallback", "warm")]
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


def main():
    cases, gains, branches, losses = [], [], [], []
    for sub, nets in RUNS:
        for s in (11, 12, 13):
            nv = find(os.path.join(HERE, sub, f"seed{s}"), "eval_vags-no-viewpoint")
            va = find(os.path.join(HERE, sub, f"seed{s}"), "eval_vags")
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
    print("\nObjects that left the table without a grasp, 6-10 objects (250 rounds)\n")
    print("| seed | networks | policy | attempts | objects lost | per attempt | per direct attempt | per move |")
    print("|---:|---|---|---:|---:|---:|---:|---:|")
    for s, nets, policy, (a, lost, per, direct, moved) in losses:
        print(f"| {s} | {nets} | {policy} | {a} | {lost} | {per:.3f} | {direct:.3f} | "
              + ("" if moved != moved else f"{moved:.3f}") + " |")
    margin_fits()
    sweep()


def sweep():
    """The Fig. 6 sweep on run g54f (seed 11, 20 rounds a group): one row per threshold."""
    import json
    with open(os.path.join(HERE, "sweep", "eval_vags_r20_sweep.json")) as f:
        d = json.load(f)
    rows = d["rows"] if isinstance(d, dict) and "rows" in d else d
    print("\nFig. 6 sweep (run g54f, seed 11, groups 1-10 x 20 rounds)\n")
    print("| kind | threshold | success % | clearing % | motion number | moves % | picks/h |\n|---|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        o = r["overall"]
        print(f"| {r['kind']} | {r['threshold']:+.2f} | {100 * o['grasp_success_rate']:.1f} | "
              f"{100 * o['clearing_rate']:.1f} | {o['motion_number']:.2f} | {100 * o['viewpoint_rate']:.1f} | "
              f"{o['picks_per_hour']:.0f} |")


if __name__ == "__main__":
    main()
