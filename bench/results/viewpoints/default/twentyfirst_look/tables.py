"""Prints the tables of bench/RESULTS.md, "Viewpoints that pay, twenty-first look": the `gpu`
preset trained from a bare machine (with stage 2 compiled ahead), VAGS and ``--no-viewpoint`` on
the default scenes, seeds 11-13, and VAGS with ``vags.max_motion_number=1.3`` on the run's 8-bin
gate table and on the same states refit over 16 bins.
Run from anywhere: python bench/results/viewpoints/default/twentyfirst_look/tables.py"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(os.path.dirname(HERE)))
from report_tables import branches_table, differences, find, row, table  # noqa: E402

VARIANTS = (("", "VAGS (8 bins, no cap)"), ("cap130", "VAGS, cap 1.3 (8 bins)"),
            ("bins16_cap130", "VAGS, cap 1.3 (16 bins)"))


def main():
    cases, gains, branches = [], [], []
    for s in (11, 12, 13):
        nv = find(os.path.join(HERE, f"seed{s}"), "eval_vags-no-viewpoint")
        cases.append((s, "run m52", "`--no-viewpoint`", nv))
        rn = row(nv)
        for sub, label in VARIANTS:
            va = find(os.path.join(HERE, sub, f"seed{s}"), "eval_vags")
            cases.append((s, "run m52", label, va))
            rv = row(va)
            gains.append((f"{s}, {label}", rv[0] - rn[0], rv[1] - rn[1], rv[2] - rn[2]))
            o = va["overall"]
            branches.append((s, label, o["success_direct"], o["success_after_move"], o["first_attempt_success"],
                             nv["overall"]["first_attempt_success"]))
    table("The default scenes, groups 1-10 x 50 rounds", cases)
    differences("Points, VAGS − ablation", ["success", "6-10 success", "6-10 clearing"], gains)
    branches_table("gate", branches)


if __name__ == "__main__":
    main()
