"""Prints the tables of bench/RESULTS.md, "Viewpoints that pay, eleventh look", from the reports
beside this file and in ../seed<S> (the sixth run's stage-3 VAGS) and ../../eighth_run/table_<a|b>.
Run from anywhere: python bench/results/viewpoints/default/sixth_run/stage2_networks/tables.py"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
EIGHTH = os.path.join(HERE, "..", "..", "eighth_run")
sys.path.insert(0, os.path.join(HERE, "..", "..", ".."))
from report_tables import find, table  # noqa: E402


def main():
    cases = []
    for s in (11, 12, 13):
        cases += [(s, "after stage 3", "`--no-viewpoint`", find(os.path.join(HERE, "stage3", f"seed{s}"),
                                                               "eval_vags-no-viewpoint")),
                  (s, "after stage 2", "`--no-viewpoint`", find(os.path.join(HERE, "stage2", f"seed{s}"),
                                                               "eval_vags-no-viewpoint")),
                  (s, "after stage 3 (ninth look)", "VAGS", find(os.path.join(HERE, "..", f"seed{s}"), "eval_vags")),
                  (s, "after stage 2", "VAGS", find(os.path.join(HERE, "stage2", f"seed{s}"), "eval_vags"))]
    table("Sixth run (r16): its networks after stage 2 and after stage 3", cases)
    cases = []
    for s in (11, 12, 13):
        for t in ("a", "b"):
            folder = os.path.join(EIGHTH, f"table_{t}", f"seed{s}")
            cases += [(s, f"after stage 2, table {t}", "`--no-viewpoint`", find(folder, "eval_vags-no-viewpoint")),
                      (s, f"after stage 2, table {t}", "VAGS", find(folder, "eval_vags"))]
    table("Eighth run: its networks after stage 2, two tables measured on them", cases)


if __name__ == "__main__":
    main()
