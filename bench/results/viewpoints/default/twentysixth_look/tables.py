"""Prints the tables of bench/RESULTS.md, "Viewpoints that pay, twenty-sixth look": four `gpu`
pipelines on one 2 x H200 machine, one per GPU, two at a time (``driver.sh``, then
``driver2.sh``): g60 (seed 0) and g61 (seed 1) as the preset is, g62 (seed 0) and g63 (seed 1)
with ``vags.train_close_score=success``.  Per run: the ablation (``seed<S>/eval_vags-no-viewpoint``),
VAGS (``seed<S>/eval_vags``) and VAGS capped at a motion number of 1.3 (``cap1.3/seed<S>``),
default scenes, groups 1-10 x 50 rounds, seeds 11-13; for g60 and g61 also the ablation and the
cap on seeds 14-16 (``more/``, asked after the rules' evaluations had run); the Fig. 6 sweeps of
g60 and g62 (``sweep/``).  Then the two rules ``driver.sh`` fixed before anything ran.
Run from anywhere: python bench/results/viewpoints/default/twentysixth_look/tables.py"""
import json
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(os.path.dirname(HERE)))
from report_tables import branches_table, differences, find, lost_row, lost_table, row, table  # noqa: E402

RUNS = (("g60", "g60, preset"), ("g61", "g61, preset"), ("g62", "g62, train success"), ("g63", "g63, train success"))
POLICIES = (("", "VAGS"), ("cap1.3", "VAGS, cap 1.3"))


def evaluations(run, seeds=(11, 12, 13), more=""):
    """{seed: (ablation, {policy label: report})} of one run."""
    out = {}
    for s in seeds:
        nv = find(os.path.join(HERE, run, more, f"seed{s}"), "eval_vags-no-viewpoint")
        vs = {}
        for sub, label in POLICIES:
            try:
                vs[label] = find(os.path.join(HERE, run, more, sub, f"seed{s}"), "eval_vags")
            except FileNotFoundError:
                pass
        out[s] = (nv, vs)
    return out


def print_look(runs, seeds, more, title):
    cases, gains, branches, losses = [], [], [], []
    summary = {}
    for run, nets in runs:
        for s, (nv, vs) in evaluations(run, seeds, more).items():
            cases.append((s, nets, "`--no-viewpoint`", nv))
            losses.append((s, nets, "`--no-viewpoint`", lost_row(nv)))
            rn = row(nv)
            for label, va in vs.items():
                cases.append((s, nets, label, va))
                rv = row(va)
                gains.append((f"{s}, {nets}, {label}", rv[0] - rn[0], rv[1] - rn[1], rv[2] - rn[2]))
                summary.setdefault((run, label), []).append((rv[0], rv[1] - rn[1], rv[2] - rn[2], rv[3], rv[5]))
                o = va["overall"]
                branches.append((s, f"{nets}, {label}", o["success_direct"], o["success_after_move"],
                                 o["first_attempt_success"], nv["overall"]["first_attempt_success"]))
                losses.append((s, nets, label, lost_row(va)))
    table(title, cases)
    differences("Points, VAGS − ablation", ["success", "6-10 success", "6-10 clearing"], gains)
    branches_table("networks, policy", branches)
    lost_table(losses)
    return summary


def rules(summary):
    """The two rules of driver.sh / driver2.sh, on seeds 11-13."""
    print("\nThe rules (seeds 11-13)\n")
    print("| run | policy | success % | 6-10 margins | mean 6-10 margin | motion numbers | moves at 1 object % |")
    print("|---|---|---:|---|---:|---|---|")
    for (run, label), v in summary.items():
        a = np.array(v)
        print(f"| {run} | {label} | {a[:, 0].mean():.1f} | {', '.join(f'{x:+.1f}' for x in a[:, 1])} | "
              f"{a[:, 1].mean():+.1f} | {', '.join(f'{x:.3f}' for x in a[:, 3])} | "
              f"{', '.join(f'{x:.1f}' for x in a[:, 4])} |")
    cap = [summary[(r, "VAGS, cap 1.3")] for r in ("g60", "g61")]
    rule1 = all(m < 1.35 and d >= 5 for v in cap for (_, d, _, m, _) in v)
    print(f"\nrule 1 (cap 1.3 on g60 and g61: motion number < 1.35 and 6-10 margin >= +5 on every seed): "
          f"{'holds' if rule1 else 'fails'}")
    label = "VAGS, cap 1.3" if rule1 else "VAGS"
    base = np.array([x for r in ("g60", "g61") for x in summary[(r, label)]])
    var = np.array([x for r in ("g62", "g63") for x in summary[(r, label)]])
    d_margin, d_success = var[:, 1].mean() - base[:, 1].mean(), var[:, 0].mean() - base[:, 0].mean()
    rule2 = d_margin >= 3 and d_success >= -1
    print(f"rule 2 ({label}; g62+g63 against g60+g61: mean 6-10 margin {d_margin:+.1f} points (needs >= +3), "
          f"success {d_success:+.1f} (needs >= -1)): {'holds' if rule2 else 'fails'}")


def sweep(run):
    with open(os.path.join(HERE, run, "sweep", "eval_vags_r20_sweep.json")) as f:
        d = json.load(f)
    print(f"\nThe Fig. 6 sweep on {run} (seed 11, 20 rounds a group)\n")
    print("| threshold (rate gate's move value) | success % | clearing % | motion number | moves % | picks/h |")
    print("|---:|---:|---:|---:|---:|---:|")
    for p in d["rows"]:
        o = p["overall"]
        print(f"| {p['threshold']:+.2f} | {100 * o['grasp_success_rate']:.1f} | {100 * o['clearing_rate']:.1f} | "
              f"{o['motion_number']:.2f} | {100 * o['viewpoint_rate']:.1f} | {o['picks_per_hour']:.0f} |")


def main():
    summary = print_look(RUNS, (11, 12, 13), "", "The default scenes, groups 1-10 x 50 rounds, seeds 11-13")
    rules(summary)
    more = print_look(RUNS[:2], (14, 15, 16), "more", "Seeds 14-16 (asked after the rules' evaluations had run)")
    print("\n| run | policy | seeds 14-16: success % | 6-10 margins | motion numbers |\n|---|---|---:|---|---|")
    for (run, label), v in more.items():
        a = np.array(v)
        print(f"| {run} | {label} | {a[:, 0].mean():.1f} | {', '.join(f'{x:+.1f}' for x in a[:, 1])} | "
              f"{', '.join(f'{x:.3f}' for x in a[:, 3])} |")
    for run in ("g60", "g62"):
        sweep(run)


if __name__ == "__main__":
    main()
