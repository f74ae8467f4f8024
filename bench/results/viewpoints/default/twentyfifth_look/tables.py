"""Prints the tables of bench/RESULTS.md, "Viewpoints that pay, twenty-fifth look": the `gpu`
preset trained twice on one H200, each time on a bare machine (``first``: run g58; ``second``:
run g59); per training, the gate table measured with the grasp after a move scored by GDNet's Q
(``q/``, the pipeline's) and again by the success net (``success/``), compared on the same piles
(``paired.json``, bench/paired_tables.py); VAGS under each (g59: "success" only) and
``--no-viewpoint``, default scenes, groups 1-10 x 50 rounds, seeds 11-13.  Two folders hold
evaluations the cap bugs spoiled: ``first/cap_not_applied`` (the cap reached only the report) and
``second/cap_all_moves`` (a capped table moved on every attempt).
Run from anywhere: python bench/results/viewpoints/default/twentyfifth_look/tables.py"""
import json
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(os.path.dirname(HERE)))
from report_tables import branches_table, differences, find, lost_row, lost_table, row, table  # noqa: E402

sys.path.insert(0, os.path.join(HERE, *[os.pardir] * 4))  # bench/
from paired_tables import print_report  # noqa: E402

# (folder, networks label, VAGS evaluations: (sub-folder, label))
RUNS = (("first", "run g58", (("", "VAGS, q"), ("success", "VAGS, success"),
                              ("success_repeat", "VAGS, success, repeat"),
                              ("cap_not_applied", "VAGS, success, \"cap 1.3\" (not applied)"))),
        ("second", "run g59", (("success", "VAGS, success"),
                               ("cap_all_moves", "VAGS, success, \"cap 1.3\" (every attempt moved)"))))


def main():
    for sub, nets, _ in RUNS:
        with open(os.path.join(HERE, sub, "paired.json")) as f:
            print(f"\n{nets}, the gate table with each score:\n")
            print_report(json.load(f))
    cases, gains, branches, losses = [], [], [], []
    for sub, nets, variants in RUNS:
        for s in (11, 12, 13):
            nv = find(os.path.join(HERE, sub, f"seed{s}"), "eval_vags-no-viewpoint")
            cases.append((s, nets, "`--no-viewpoint`", nv))
            losses.append((s, nets, "`--no-viewpoint`", lost_row(nv)))
            rn = row(nv)
            for v, label in variants:
                va = find(os.path.join(HERE, sub, v, f"seed{s}"), "eval_vags")
                cases.append((s, nets, label, va))
                rv = row(va)
                gains.append((f"{s}, {nets}, {label}", rv[0] - rn[0], rv[1] - rn[1], rv[2] - rn[2]))
                o = va["overall"]
                if o["success_direct"] is not None:  # None where every attempt moved
                    branches.append((s, f"{nets}, {label}", o["success_direct"], o["success_after_move"],
                                     o["first_attempt_success"], nv["overall"]["first_attempt_success"]))
                    losses.append((s, nets, label, lost_row(va)))
    table("The default scenes, groups 1-10 x 50 rounds", cases)
    differences("Points, VAGS − ablation", ["success", "6-10 success", "6-10 clearing"], gains)
    branches_table("networks, policy", branches)
    lost_table(losses)


if __name__ == "__main__":
    main()
