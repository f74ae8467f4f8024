"""Prints the tables of bench/RESULTS.md, "Viewpoints that pay, twenty-fourth look": the `gpu`
preset trained twice on one H200 (``cold``: a bare machine, run g56; ``warm``: right after, caches
warm, run g57); per training, how well each success estimate ranks the direct grasp
(``estimates.json``, bench/gate_estimates.py); VAGS under the "grasp" table, under the table refit
on another estimate (``symmetric`` for g56, ``window`` for g57), a repeat of the first (g56), and
``--no-viewpoint``, default scenes, seeds 11-13; the 6-10 margin against the moves over the
twentieth to twenty-fourth looks.
Run from anywhere: python bench/results/viewpoints/default/twentyfourth_look/tables.py"""
import json
import os
import re
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(os.path.dirname(HERE)))
from report_tables import differences, find, margin_fits, row, table  # noqa: E402

sys.path.insert(0, os.path.join(HERE, *[os.pardir] * 4))  # bench/
from gate_estimates import print_report  # noqa: E402

# (folder, networks label, VAGS variants: (sub-folder, label))
RUNS = (("cold", "run g56", (("", "VAGS, grasp table"), ("repeat", "VAGS, grasp table, repeat"),
                             ("symmetric", "VAGS, symmetric table"))),
        ("warm", "run g57", (("", "VAGS, grasp table"), ("window", "VAGS, window table"))))

EVALS = [("twentieth_look", "", "")] + [("twentyfirst_look", v, "") for v in ("", "cap130", "bins16_cap130")] \
    + [("twentysecond_look", r, r) for r in ("cold", "warm")] \
    + [("twentythird_look", r, r) for r in ("fallback", "warm")] \
    + [("twentyfourth_look", os.path.join(r, v), r) for r, _, variants in RUNS for v, _ in variants]


def estimates():
    """Each training's estimates (``bench/gate_estimates.py``'s report, kept as estimates.json)."""
    for sub, nets, _ in RUNS:
        with open(os.path.join(HERE, sub, "estimates.json")) as f:
            e = json.load(f)
        print(f"\n{nets}:\n")
        print_report(e)


def logged_rows(path):
    """Per seed, from an eval.py log: (overall success %, 6-10 success %, 6-10 clearing %, motion
    number) read from its printed group tables (for the evaluation whose reports were overwritten)."""
    out, groups = [], {}
    for line in open(path):
        m = re.match(r"\| (\d+) \| (\d+) \| (\d+) \| (\d+) \| [\d.]+ \| ([\d.]+) \| ([\d.]+) \|", line)
        if m:
            groups[int(m.group(1))] = tuple(float(x) for x in m.groups()[1:])
        if line.startswith("| **overall"):
            out.append(groups)
            groups = {}
    rows = []
    for g in out:
        big = [g[k] for k in range(6, 11)]
        att, succ = sum(b[1] for b in g.values()), sum(b[2] for b in g.values())
        rows.append((100 * succ / att, 100 * sum(b[2] for b in big) / sum(b[1] for b in big),
                     sum(b[3] * b[0] for b in big) / sum(b[0] for b in big)))
    return rows


def main():
    estimates()
    cases, gains = [], []
    for sub, nets, variants in RUNS:
        for s in (11, 12, 13):
            nv = find(os.path.join(HERE, sub, f"seed{s}"), "eval_vags-no-viewpoint")
            cases.append((s, nets, "`--no-viewpoint`", nv))
            rn = row(nv)
            for v, label in variants:
                va = find(os.path.join(HERE, sub, v, f"seed{s}"), "eval_vags")
                cases.append((s, nets, label, va))
                rv = row(va)
                gains.append((f"{s}, {nets}, {label}", rv[0] - rn[0], rv[1] - rn[1], rv[2] - rn[2]))
    table("The default scenes, groups 1-10 x 50 rounds", cases)
    differences("Points, VAGS − ablation", ["success", "6-10 success", "6-10 clearing"], gains)
    print("\nrun g57's other evaluation under the window table (its reports were overwritten; from vags_e.txt):\n")
    print("| seed | success % | 6-10 success % | 6-10 clearing % | 6-10 margin | 6-10 clearing margin |\n"
          "|---:|---:|---:|---:|---:|---:|")
    for s, r in zip((11, 12, 13), logged_rows(os.path.join(HERE, "warm", "vags_e.txt"))):
        rn = row(find(os.path.join(HERE, "warm", f"seed{s}"), "eval_vags-no-viewpoint"))
        print(f"| {s} | {r[0]:.1f} | {r[1]:.1f} | {r[2]:.1f} | {r[1] - rn[1]:+.1f} | {r[2] - rn[2]:+.1f} |")
    margin_fits(os.path.dirname(HERE), EVALS)


if __name__ == "__main__":
    main()
