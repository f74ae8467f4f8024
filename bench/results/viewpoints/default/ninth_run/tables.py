"""Prints the tables of bench/RESULTS.md, "Viewpoints that pay, twelfth look", from the reports
beside this file: the ninth run's stage-2 networks without moves (stage 1's GDNet alone), and
stage 3 trained two ways from that stage 2 (vags.stage3_gdnet = direct | frozen).
Run from anywhere: python bench/results/viewpoints/default/ninth_run/tables.py"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", ".."))
from report_tables import find, row, table  # noqa: E402


def main():
    cases, gains = [], []
    for s in (11, 12, 13):
        stage2 = find(os.path.join(HERE, "stage2", f"seed{s}"), "eval_vags-no-viewpoint")
        direct_nv = find(os.path.join(HERE, "direct", f"seed{s}"), "eval_vags-no-viewpoint")
        direct = find(os.path.join(HERE, "direct", f"seed{s}"), "eval_vags")
        frozen = find(os.path.join(HERE, "frozen", f"seed{s}"), "eval_vags")
        cases += [(s, "after stage 2", "`--no-viewpoint`", stage2),
                  (s, "stage 3 direct", "`--no-viewpoint`", direct_nv),
                  (s, "stage 3 direct", "VAGS", direct),
                  (s, "stage 3 frozen", "VAGS", frozen)]
        r2, rdn, rd, rf = row(stage2), row(direct_nv), row(direct), row(frozen)
        gains.append((s, rd[0] - rdn[0], rd[1] - rdn[1], rd[2] - rdn[2], rd[0] - r2[0], rd[1] - r2[1],
                      rf[0] - r2[0], rf[1] - r2[1], rf[2] - r2[2]))
    table("Ninth run: stage 3 two ways from one stage 2", cases)
    print("\nVAGS minus an ablation, points (success, 6-10 success, 6-10 clearing)\n")
    print("| seed | direct - its ablation | | | direct - stage 2 ablation | | frozen - stage 2 ablation "
          "(= its own) | | |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for g in gains:
        print("| " + " | ".join([str(g[0])] + [f"{x:+.1f}" for x in g[1:]]) + " |")


if __name__ == "__main__":
    main()
