"""Prints the tables of bench/RESULTS.md, "Viewpoints that pay, twenty-second look": the `gpu`
preset trained twice on one bare H100 (cold, then with the compile cache warm), VAGS and
``--no-viewpoint`` on the default scenes, seeds 11-13, for each training; and, on 6-10 objects,
where objects left the table (per attempt, direct grasps and grasps after a move); and the 6-10
margin against the moves and the motion number over the twentieth to twenty-second looks.
Run from anywhere: python bench/results/viewpoints/default/twentysecond_look/tables.py"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(os.path.dirname(HERE)))
from report_tables import vags_against_ablation  # noqa: E402

RUNS = (("cold", "run g53 (cold)"), ("warm", "run g53w (warm)"))


# The VAGS evaluations of the margin fit: (look, VAGS folder, ablation folder).
EVALS = [("twentieth_look", "", "")] + [("twentyfirst_look", v, "") for v in ("", "cap130", "bins16_cap130")] \
    + [("twentysecond_look", r, r) for r in ("cold", "warm")]


def main():
    vags_against_ablation(HERE, RUNS, EVALS)


if __name__ == "__main__":
    main()
