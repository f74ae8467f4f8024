"""Prints the tables of bench/RESULTS.md, "Viewpoints that pay, eighteenth look": two runs trained
on the "edge" scene variant (``--config gpu-edge``; the first's logs in ``trained_run/``, its
reports in ``trained_run/seed<S>/``, moved there from ``seed<S>/`` by the thirty-first look;
the second's in ``second_trained_run/``, with VAGS under the "success" gate too), VAGS and
``--no-viewpoint`` on the edge scenes, seeds 11-13, beside the sixth run's networks (trained
on the default scenes) on the same scenes (``sixth_run_networks/``, the seventeenth look).
Run from anywhere: python bench/results/viewpoints/edge/tables.py"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, ".."))
from report_tables import branches_table, differences, find, row, table  # noqa: E402

SIXTH = os.path.join(HERE, "sixth_run_networks")
SECOND = os.path.join(HERE, "second_trained_run")
FIRST = os.path.join(HERE, "trained_run")


def main():
    cases, gains, branches = [], [], []
    runs = (("edge run 1", FIRST, ("eval_vags",)),
            ("edge run 2", SECOND, ("eval_vags", "eval_vags-success-gate")),
            ("sixth run (default scenes)", SIXTH, ("eval_vags",)))
    for nets, folder, names in runs:
        for s in (11, 12, 13):
            nv = find(os.path.join(folder, f"seed{s}"), "eval_vags-no-viewpoint")
            cases.append((s, nets, "`--no-viewpoint`", nv))
            for name in names:
                va = find(os.path.join(folder, f"seed{s}"), name)
                policy = "VAGS, success gate" if name.endswith("success-gate") else "VAGS"
                cases.append((s, nets, policy, va))
                rn, rv = row(nv), row(va)
                gains.append((f"{s} ({nets}, {policy})", rv[0] - rn[0], rv[1] - rn[1], rv[2] - rn[2]))
                o = va["overall"]
                branches.append((s, f"{nets}, {policy}", o["success_direct"], o["success_after_move"],
                                 o["first_attempt_success"], nv["overall"]["first_attempt_success"]))
    table("The edge scenes, groups 1-10 x 50 rounds", cases)
    differences("Points, VAGS − ablation", ["success", "6-10 success", "6-10 clearing"], gains)
    branches_table("networks", branches)


if __name__ == "__main__":
    main()
