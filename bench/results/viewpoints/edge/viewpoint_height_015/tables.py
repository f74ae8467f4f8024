"""Prints the tables of bench/RESULTS.md, "Viewpoints that pay, nineteenth look": a run trained on
the edge scenes with the close view 0.15 m above the chosen cell (``--config gpu-edge --set
camera.viewpoint_height=0.15``), VAGS and ``--no-viewpoint`` on the edge scenes, seeds 11-13,
beside the eighteenth look's two runs at the preset's 0.25 m (``../seed<S>/``,
``../second_trained_run/``).
Run from anywhere: python bench/results/viewpoints/edge/viewpoint_height_015/tables.py"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
EDGE = os.path.dirname(HERE)
sys.path.insert(0, os.path.dirname(EDGE))
from report_tables import branches_table, differences, find, row, table  # noqa: E402


def main():
    cases, gains, branches = [], [], []
    runs = (("0.15 m run", HERE), ("0.25 m, edge run 1", EDGE), ("0.25 m, edge run 2", os.path.join(EDGE, "second_trained_run")))
    for nets, folder in runs:
        for s in (11, 12, 13):
            nv, va = find(os.path.join(folder, f"seed{s}"), "eval_vags-no-viewpoint"), find(os.path.join(folder, f"seed{s}"), "eval_vags")
            cases += [(s, nets, "`--no-viewpoint`", nv), (s, nets, "VAGS", va)]
            rn, rv = row(nv), row(va)
            gains.append((f"{s} ({nets})", rv[0] - rn[0], rv[1] - rn[1], rv[2] - rn[2]))
            o = va["overall"]
            branches.append((s, nets, o["success_direct"], o["success_after_move"], o["first_attempt_success"],
                             nv["overall"]["first_attempt_success"]))
    table("The edge scenes, groups 1-10 x 50 rounds", cases)
    differences("Points, VAGS − ablation", ["success", "6-10 success", "6-10 clearing"], gains)
    branches_table("networks", branches)


if __name__ == "__main__":
    main()
