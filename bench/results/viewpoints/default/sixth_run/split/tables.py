"""Prints the tables of bench/RESULTS.md, "Viewpoints that pay, fifteenth look", from the reports
beside this file: the sixth run's networks with the GDNets the gate table picked among three
("split": stage 2's for direct grasps, stage 3's after a move), with and without moves, and
VAGS with the pick it did not keep (stage 2's GDNet for both, ``alt/``), on seeds 11-16.
Run from anywhere: python bench/results/viewpoints/default/sixth_run/split/tables.py"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", ".."))
from report_tables import differences, find, row, table  # noqa: E402


def main():
    cases, gains = [], []
    for s in (11, 12, 13, 14, 15, 16):
        nv = find(os.path.join(HERE, f"seed{s}"), "eval_vags-no-viewpoint")
        split = find(os.path.join(HERE, f"seed{s}"), "eval_vags")
        both2 = find(os.path.join(HERE, "alt", f"seed{s}"), "eval_vags")
        cases += [(s, "GDNet of stage 2", "`--no-viewpoint`", nv),
                  (s, "split (after a move: stage 3's)", "VAGS", split),
                  (s, "GDNet of stage 2 for both", "VAGS", both2)]
        rn, rs, r2 = row(nv), row(split), row(both2)
        gains.append((s, rs[0] - rn[0], rs[1] - rn[1], rs[2] - rn[2], r2[0] - rn[0], r2[1] - rn[1], r2[2] - rn[2],
                      rs[0] - r2[0], rs[1] - r2[1]))
    table("Sixth run's networks: the split pick against stage 2's GDNet for both", cases)
    differences("Points: split VAGS − ablation (success, 6-10 success, 6-10 clearing); stage-2 VAGS − ablation "
                "(same); split − stage-2 VAGS (success, 6-10 success)",
                ["split − abl.: success", "6-10 success", "6-10 clearing", "stage 2 − abl.: success", "6-10 success",
                 "6-10 clearing", "split − stage 2: success", "6-10 success"], gains)

if __name__ == "__main__":
    main()
