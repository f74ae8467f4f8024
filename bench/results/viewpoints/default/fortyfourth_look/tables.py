#!/usr/bin/env python3
"""The forty-fourth look's tables and its rule's verdict (driver.sh, fixed before the run): the
trainings s59-s61 (the gpu preset as it is), each with and without vags.gate_min_z=2 where its gate
table moves in a bin within two standard errors of 0, against its own ablation.  Written before
the run; reads the run folders under TOP (default: this folder).

    python bench/results/viewpoints/default/fortyfourth_look/tables.py [TOP]

(0) No verdict unless a training's table has such a bin and all three reports on every seed.
(1) The gpu preset takes vags.gate_min_z=2 only if, over those trainings' goal checks (five goals x
    seeds 11-13 x trainings), VAGS with it meets strictly more than VAGS without.
(2) s59's reports become the default scenes' final ones (which VAGS reports: by (1)).
Then s59's Fig. 6 sweep (s59/sweep/eval_vags_r20_sweep.json, gzipped or not) as a table, drawn to
fig6.png beside this file.
"""
import glob
import gzip
import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, *[".."] * 5))
sys.path.insert(0, os.path.join(ROOT, "bench"))
sys.path.insert(0, ROOT)
import viewpoint_goals  # noqa: E402
from vags_jax.policies import rate_gate  # noqa: E402

SEEDS = (11, 12, 13)
ABLATION = "vags-no-viewpoint"


def main(top):
    judged = []
    for run in sorted(glob.glob(os.path.join(top, "s*"))):
        if not os.path.isfile(os.path.join(run, "gate.json")):
            continue
        table = rate_gate.from_dict(rate_gate.read(run))
        moving = [k for k, v in enumerate(table.move_value) if v > 0]
        close = rate_gate.close_moving_bins(table)
        print(f"## {os.path.basename(run)}: the gate table\n")
        print(rate_gate.describe(table))
        print(f"\nmoving bins {moving}; moving bins within two standard errors of 0: {close}\n", flush=True)
        for policy in ("vags", "vags-z2"):
            if viewpoint_goals.checks_met(run, policy, ABLATION, SEEDS) is None:
                continue
            print(f"### {os.path.basename(run)}: {policy} against {ABLATION}\n", flush=True)
            subprocess.run([sys.executable, os.path.join(ROOT, "bench/viewpoint_goals.py"), run, "--goals",
                            "--policies", policy, ABLATION], check=True)
            print()
        plain = viewpoint_goals.checks_met(run, "vags", ABLATION, SEEDS)
        z2 = viewpoint_goals.checks_met(run, "vags-z2", ABLATION, SEEDS)
        if close and plain is not None and z2 is not None:
            judged.append((os.path.basename(run), plain, z2))
    print("## The rule\n")
    adopt = False
    if not judged:
        print("(0) no training has a moving bin within two standard errors of 0 and all its reports: no verdict; "
              "vags.gate_min_z stays 0.")
    else:
        adopt = verdict(judged)
    final = os.path.join(top, "s59")
    # The driver runs the -z2 reports only where the table has such a bin; elsewhere z=2 plays as the plain ones.
    policy = "vags-z2" if adopt and viewpoint_goals.checks_met(final, "vags-z2", ABLATION, SEEDS) else "vags"
    if viewpoint_goals.checks_met(final, policy, ABLATION, SEEDS) is None:
        print(f"\n(2) s59 lacks its {policy} or {ABLATION} reports: the final reports stay f41's.")
    else:
        print(f"\n(2) the final reports at bench/results/viewpoints/default/seed<S>/ become s59's: "
              f"eval_{policy}.json as eval_vags.json, and eval_{ABLATION}.json.")
    sweep(top)


def sweep(top):
    """s59's threshold sweep as a Markdown table, and its plot (fig6.png beside this file)."""
    path = os.path.join(top, "s59", "sweep", "eval_vags_r20_sweep.json")
    if not os.path.exists(path) and not os.path.exists(path + ".gz"):
        print("\nno sweep")
        return
    with (open(path) if os.path.exists(path) else gzip.open(path + ".gz", "rt")) as f:
        rows = json.load(f)["rows"]
    print("\n## s59's Fig. 6 sweep (seed 11, 20 rounds a group)\n")
    print("| threshold (rate gate's move value) | success % | clearing % | motion number | moves % | picks/h |")
    print("|---:|---:|---:|---:|---:|---:|")
    for r in sorted(rows, key=lambda r: r["threshold"]):
        o = r["overall"]
        print(f"| {r['threshold']:+.2f} | {100 * o['grasp_success_rate']:.1f} | {100 * o['clearing_rate']:.1f} | "
              f"{o['motion_number']:.2f} | {100 * o['viewpoint_rate']:.1f} | {o['picks_per_hour']:.0f} |")
    from vags_jax.benchmark import reports

    reports.plot_sweep(rows, os.path.join(HERE, "fig6.png"), title="s59 (the gpu preset): grasp success vs threshold")
    print("\ndrew fig6.png")


def verdict(judged) -> bool:
    """Prints rule (1)'s table and verdict over the judged trainings; True where it adopts."""
    print("| training | VAGS: checks met | VAGS, vags.gate_min_z=2: checks met | of |\n|---|---:|---:|---:|")
    for name, plain, z2 in judged:
        print(f"| {name} | {plain[0]} | {z2[0]} | {plain[1]} |")
    a, b, n = (sum(p[0] for _, p, _ in judged), sum(z[0] for _, _, z in judged), sum(p[1] for _, p, _ in judged))
    print(f"| all | {a} | {b} | {n} |")
    adopt = b > a
    print(f"\n(1) {'met' if adopt else 'not met'}: the gpu preset {'takes' if adopt else 'does not take'} "
          "vags.gate_min_z=2.")
    return adopt


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else HERE)
