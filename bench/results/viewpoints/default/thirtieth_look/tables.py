"""Prints the tables of bench/RESULTS.md, "Viewpoints that pay, thirtieth look": one new `gpu`
pipeline (training seed 14; ``driver.sh``), evaluated on seeds 11-13, groups 1-10 x 50 rounds,
as the ablation and VAGS with the direct grasp planned by GDNet's argmax (``q/``, the preset)
and by the success net's half-turn-mean argmax (``success/``, ``vags.direct_score=success``, its
own table); the two tables' bins; and the states of ``success/gate_states.npz``, each grasped
three ways, paired (bench/planner_comparison.py).
Run from anywhere: python bench/results/viewpoints/default/thirtieth_look/tables.py"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, *[os.pardir] * 4))
import planner_comparison  # noqa: E402

if __name__ == "__main__":
    sys.exit(planner_comparison.main([HERE]))
