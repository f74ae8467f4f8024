"""Prints the tables of bench/RESULTS.md, "Viewpoints that pay, fourteenth look", from the reports
in ../seed<S> (the default scenes' final run) and beside this file: the eleventh run (today's defaults: stage 3 "all", the GDNet picked by the gate
table, which kept stage 2's) with and without moves, stage 2's networks without moves, and a
second evaluation of the ablation (``repeat_nv/``).
Run from anywhere: python bench/results/viewpoints/default/eleventh_run/tables.py"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", ".."))
from report_tables import differences, find, row, table  # noqa: E402


def main():
    cases, gains = [], []
    for s in (11, 12, 13):
        stage2 = find(os.path.join(HERE, "stage2", f"seed{s}"), "eval_vags-no-viewpoint")
        nv = find(os.path.join(HERE, f"seed{s}"), "eval_vags-no-viewpoint")
        again = find(os.path.join(HERE, "repeat_nv", f"seed{s}"), "eval_vags-no-viewpoint")
        vags = find(os.path.join(HERE, f"seed{s}"), "eval_vags")
        cases += [(s, "after stage 2", "`--no-viewpoint`", stage2),
                  (s, "the run's (GDNet of stage 2)", "`--no-viewpoint`", nv),
                  (s, "the run's (GDNet of stage 2)", "`--no-viewpoint`, again", again),
                  (s, "the run's (GDNet of stage 2)", "VAGS", vags)]
        r2, rn, ra, rv = row(stage2), row(nv), row(again), row(vags)
        gains.append((s, rv[0] - rn[0], rv[1] - rn[1], rv[2] - rn[2], rv[1] - ra[1], rv[2] - ra[2],
                      rv[1] - r2[1], rv[2] - r2[2]))
    table("Eleventh run: today's defaults", cases)
    differences("VAGS minus an ablation, points",
                ["− its ablation: success", "6-10 success", "6-10 clearing",
                 "− the ablation again: 6-10 success", "6-10 clearing", "− stage-2 ablation: 6-10 success",
                 "6-10 clearing"], gains)


if __name__ == "__main__":
    main()
