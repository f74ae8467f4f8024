"""Prints the tables of bench/RESULTS.md, "Viewpoints that pay, seventeenth look": the sixth run's
networks (trained on the default scenes; split GDNet pick, close region "seen") on the "edge"
scene variant, VAGS and ``--no-viewpoint``, seeds 11-13, beside the same networks on the default
scenes (``default/sixth_run/split/seed*``, the fifteenth look).
Run from anywhere: python bench/results/viewpoints/edge/sixth_run_networks/tables.py"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", ".."))
from report_tables import branches_table, differences, find, row, table  # noqa: E402

DEFAULT = os.path.join(HERE, "..", "..", "default", "sixth_run", "split")


def main():
    cases, gains, branches = [], [], []
    for scenes, folder in (("edge", HERE), ("default", DEFAULT)):
        for s in (11, 12, 13):
            nv = find(os.path.join(folder, f"seed{s}"), "eval_vags-no-viewpoint")
            va = find(os.path.join(folder, f"seed{s}"), "eval_vags")
            cases += [(s, scenes, "`--no-viewpoint`", nv), (s, scenes, "VAGS", va)]
            rn, rv = row(nv), row(va)
            gains.append((f"{s} ({scenes})", rv[0] - rn[0], rv[1] - rn[1], rv[2] - rn[2]))
            o = va["overall"]
            if "success_after_move" in o:
                branches.append((s, scenes, o["success_direct"], o["success_after_move"], o["first_attempt_success"],
                                 nv["overall"]["first_attempt_success"]))
    table("The sixth run's networks on the edge and default scenes", cases)
    differences("Points, VAGS − ablation", ["success", "6-10 success", "6-10 clearing"], gains)
    branches_table("scenes", branches)


if __name__ == "__main__":
    main()
