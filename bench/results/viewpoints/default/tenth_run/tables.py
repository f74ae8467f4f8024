"""Prints the tables of bench/RESULTS.md, "Viewpoints that pay, thirteenth look", from the reports
beside this file: the tenth run (the default, stage 3 "direct") without moves after stage 2 and
after stage 3, VAGS, and stage 3 "all" trained from the same stage-2 checkpoint.
Run from anywhere: python bench/results/viewpoints/default/tenth_run/tables.py"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", ".."))
from report_tables import differences, find, row, table  # noqa: E402


def main():
    cases, gains = [], []
    for s in (11, 12, 13):
        stage2 = find(os.path.join(HERE, "stage2", f"seed{s}"), "eval_vags-no-viewpoint")
        direct_nv = find(os.path.join(HERE, f"seed{s}"), "eval_vags-no-viewpoint")
        direct = find(os.path.join(HERE, f"seed{s}"), "eval_vags")
        all_nv = find(os.path.join(HERE, "stage3_all", f"seed{s}"), "eval_vags-no-viewpoint")
        all_ = find(os.path.join(HERE, "stage3_all", f"seed{s}"), "eval_vags")
        cases += [(s, "after stage 2", "`--no-viewpoint`", stage2),
                  (s, "stage 3 direct", "`--no-viewpoint`", direct_nv),
                  (s, "stage 3 direct", "VAGS", direct),
                  (s, "stage 3 all", "`--no-viewpoint`", all_nv),
                  (s, "stage 3 all", "VAGS", all_)]
        r2, rdn, rd, ran, ra = row(stage2), row(direct_nv), row(direct), row(all_nv), row(all_)
        gains.append((s, rd[0] - rdn[0], rd[1] - rdn[1], rd[2] - rdn[2], rd[1] - r2[1],
                      ra[0] - ran[0], ra[1] - ran[1], ra[2] - ran[2], ra[1] - r2[1]))
    table("Tenth run: stage 3 direct (the default) and all from one stage 2", cases)
    differences("VAGS minus an ablation, points",
                ["direct - its ablation: success", "6-10 success", "6-10 clearing",
                 "direct - stage-2 ablation: 6-10 success", "all - its ablation: success", "6-10 success",
                 "6-10 clearing", "all - stage-2 ablation: 6-10 success"], gains)


if __name__ == "__main__":
    main()
