"""Prints the tables of bench/RESULTS.md, "Viewpoints that pay, thirty-first look": two new
`gpu-edge` pipelines (training seeds 14 and 15, ``o80/`` and ``o81/``; ``driver.sh``), evaluated
on the edge scenes, seeds 11-13, groups 1-10 x 50 rounds, as the ablation and VAGS with the
direct grasp planned by GDNet's argmax (``q/``, the preset) and by the success net's
half-turn-mean argmax (``success/``, ``vags.direct_score=success``, its own table), by
bench/planner_comparison.py.  The look's rule (``driver.sh``) is its "+5 points ... one planner
on both sides" line.
Run from anywhere: python bench/results/viewpoints/edge/thirtyfirst_look/tables.py"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, *[os.pardir] * 4))
import planner_comparison  # noqa: E402

if __name__ == "__main__":
    sys.exit(planner_comparison.main([os.path.join(HERE, "o80"), os.path.join(HERE, "o81")]))
