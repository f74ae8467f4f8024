"""Prints the tables of bench/RESULTS.md, "Viewpoints that pay, eleventh look", from the reports
beside this file and in ../seed<S> (the sixth run's stage-3 VAGS) and ../../eighth_run/table_<a|b>.
Run from anywhere: python bench/results/viewpoints/default/sixth_run/stage2_networks/tables.py"""
import gzip
import json
import os

HERE = os.path.dirname(os.path.abspath(__file__))
EIGHTH = os.path.join(HERE, "..", "..", "eighth_run")


def report(path):
    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rt") as f:
        return json.load(f)


def find(folder, name):
    for p in (os.path.join(folder, name + ".json"), os.path.join(folder, name + ".json.gz")):
        if os.path.isfile(p):
            return report(p)
    raise FileNotFoundError(os.path.join(folder, name))


def row(d):
    """overall success, 6-10 success, 6-10 clearing, motion number, moves %, moves at 1 object %, picks/h"""
    o, groups = d["overall"], d["groups_metrics"]
    big = [g for g in groups if g["n_objects"] >= 6]
    s610 = sum(g["successes"] for g in big) / sum(g["attempts"] for g in big)
    c610 = sum(g["clearing_rate"] * g["rounds"] for g in big) / sum(g["rounds"] for g in big)
    one = [g for g in groups if g["n_objects"] == 1][0]
    return (100 * o["grasp_success_rate"], 100 * s610, 100 * c610, o["motion_number"], 100 * o["viewpoint_rate"],
            100 * one["viewpoint_rate"], o["picks_per_hour"])


def table(title, cases):
    print(f"\n{title}\n")
    print("| seed | networks | policy | success % | 6-10 success % | 6-10 clearing % | motion number | moves % | "
          "moves at 1 object % | picks/h |")
    print("|---:|---|---|---:|---:|---:|---:|---:|---:|---:|")
    for seed, nets, policy, d in cases:
        r = row(d)
        print(f"| {seed} | {nets} | {policy} | {r[0]:.1f} | {r[1]:.1f} | {r[2]:.1f} | {r[3]:.3f} | {r[4]:.1f} | "
              f"{r[5]:.1f} | {r[6]:.0f} |")


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
