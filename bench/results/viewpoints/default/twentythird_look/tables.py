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
from report_tables import (branches_table, differences, find, lost_row, lost_table, margin_fits, row,  # noqa: E402
                           table)

RUNS = (("fallback", "run g54f"), ("warm", "run g55w"))


# The VAGS evaluations of the margin fit: (look, VAGS folder, ablation folder).
EVALS = [("twentieth_look", "", "")] + [("twentyfirst_look", v, "") for v in ("", "cap130", "bins16_cap130")] \
    + [("twentysecond_look", r, r) for r in ("cold", "warm")] \
    + [("twentythird_look", r, r) for r in ("fallback", "warm")]


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
    lost_table(losses)
    margin_fits(os.path.dirname(HERE), EVALS)
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
