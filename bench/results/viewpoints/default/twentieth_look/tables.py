"""Prints the tables of bench/RESULTS.md, "Viewpoints that pay, twentieth look": the `gpu` preset
trained from a bare machine at 88969ae, VAGS and ``--no-viewpoint`` on the default scenes, seeds
11-13, and the warm 500-round table of seed 14.
Run from anywhere: python bench/results/viewpoints/default/twentieth_look/tables.py"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(os.path.dirname(HERE)))
from report_tables import branches_table, differences, find, row, table  # noqa: E402


def main():
    cases, gains, branches = [], [], []
    for s in (11, 12, 13):
        folder = os.path.join(HERE, f"seed{s}")
        nv, va = find(folder, "eval_vags-no-viewpoint"), find(folder, "eval_vags")
        cases += [(s, "run m51", "`--no-viewpoint`", nv), (s, "run m51", "VAGS", va)]
        rn, rv = row(nv), row(va)
        gains.append((str(s), rv[0] - rn[0], rv[1] - rn[1], rv[2] - rn[2]))
        o = va["overall"]
        branches.append((s, "run m51", o["success_direct"], o["success_after_move"], o["first_attempt_success"],
                         nv["overall"]["first_attempt_success"]))
    warm = find(os.path.join(HERE, "warm_eval"), "eval_vags_seed14")
    cases.append((14, "run m51", "VAGS (warm table)", warm))
    table("The default scenes, groups 1-10 x 50 rounds", cases)
    differences("Points, VAGS − ablation", ["success", "6-10 success", "6-10 clearing"], gains)
    branches_table("networks", branches)


if __name__ == "__main__":
    main()
