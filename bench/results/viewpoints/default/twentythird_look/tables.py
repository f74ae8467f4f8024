"""Prints the tables of bench/RESULTS.md, "Viewpoints that pay, twenty-third look": the `gpu`
preset trained twice on one H200 (``fallback``: after the compile-ahead threads crashed, with
--compile-ahead off; ``warm``: the reverted tree, compile cache warm), VAGS and ``--no-viewpoint``
on the default scenes, seeds 11-13, for each training; on 6-10 objects, where objects left the
table; the 6-10 margin against the moves and the motion number over the twentieth to
twenty-third looks; and the Fig. 6 sweep's rows.
Run from anywhere: python bench/results/viewpoints/default/twentythird_look/tables.py"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(os.path.dirname(HERE)))
from report_tables import vags_against_ablation  # noqa: E402

RUNS = (("fallback", "run g54f"), ("warm", "run g55w"))


# The VAGS evaluations of the margin fit: (look, VAGS folder, ablation folder).
EVALS = [("twentieth_look", "", "")] + [("twentyfirst_look", v, "") for v in ("", "cap130", "bins16_cap130")] \
    + [("twentysecond_look", r, r) for r in ("cold", "warm")] \
    + [("twentythird_look", r, r) for r in ("fallback", "warm")]


def main():
    vags_against_ablation(HERE, RUNS, EVALS)
    sweep()


def sweep():
    """The Fig. 6 sweep on run g54f (seed 11, 20 rounds a group): one row per threshold."""
    import json
    with open(os.path.join(HERE, "sweep", "eval_vags_r20_sweep.json")) as f:
        d = json.load(f)
    rows = d["rows"] if isinstance(d, dict) and "rows" in d else d
    print("\nFig. 6 sweep (run g54f, seed 11, groups 1-10 x 20 rounds)\n")
    print("| kind | threshold | success % | clearing % | motion number | moves % | picks/h |\n|---|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        o = r["overall"]
        print(f"| {r['kind']} | {r['threshold']:+.2f} | {100 * o['grasp_success_rate']:.1f} | "
              f"{100 * o['clearing_rate']:.1f} | {o['motion_number']:.2f} | {100 * o['viewpoint_rate']:.1f} | "
              f"{o['picks_per_hour']:.0f} |")


if __name__ == "__main__":
    main()
