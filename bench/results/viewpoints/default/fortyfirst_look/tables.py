#!/usr/bin/env python3
"""The forty-first look's tables and its rule's verdict (driver.sh, fixed before the run):
c56 (the gpu preset, seed 56, vags.success_label=clean) against s56 (the same without the label,
fortieth look).  Written before the run; reads what the driver wrote under RUN_DIR (default: this
folder's c56/).

    python bench/results/viewpoints/default/fortyfirst_look/tables.py [RUN_DIR]

(1) On the run's gate table, objects knocked off per state in the moving bins, after a move minus
    direct (gate.json "lost"): below -2.0 points and more than two standard errors below 0.
(2) The gpu preset takes the label only if (1) holds, VAGS grasps at least 85 % and is at least 5
    points above its ablation on 6-10 objects on every seed, and VAGS's 6-10 clearing pooled over
    the seeds is above its ablation's by more than s56's +1.6 points (594 against 582 of 750).
"""
import gzip
import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, *[".."] * 5))
sys.path.insert(0, os.path.join(ROOT, "bench"))
import viewpoint_goals  # noqa: E402

S56_POOLED_CLEARING = 100 * (594 - 582) / 750  # +1.6 points
SEEDS = (11, 12, 13)


def load(path):
    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rt") as f:
        return json.load(f)


def report(run, seed, policy):
    base = os.path.join(run, f"seed{seed}", f"eval_{policy}.json")
    return load(base if os.path.isfile(base) else base + ".gz")


def main(run):
    with open(os.path.join(run, "gate.json")) as f:
        gate = json.load(f)
    print(f"## The gate table ({run}/gate.json): moves in bins {[i for i, v in enumerate(gate['move_value']) if v > 0]}"
          f" of {len(gate['move_value'])}\n")
    m = gate["lost"]["moved_bins"]
    diff, se = 100 * m["difference"], 100 * m["se"]
    one = m["states"] > 0 and diff < -2.0 and diff < -2 * se
    print(f"moving bins: {m['states']} states, knocked off per 100 states: direct {100 * m['direct']:.1f}, after a move "
          f"{100 * m['moved']:.1f}, difference {diff:+.1f} ± {se:.1f}")
    print(f"(1) below -2.0 points and more than two standard errors below 0: {'met' if one else 'not met'}\n", flush=True)

    subprocess.run([sys.executable, os.path.join(ROOT, "bench/viewpoint_goals.py"), run, "--goals"], check=True)

    vags = {s: report(run, s, "vags") for s in SEEDS}
    abl = {s: report(run, s, "vags-no-viewpoint") for s in SEEDS}
    rows = {s: (viewpoint_goals.row(vags[s]), viewpoint_goals.row(abl[s])) for s in SEEDS}
    success = all(x["success"] >= 0.85 for x, _ in rows.values())
    margin = all(x["success_6_10"] - y["success_6_10"] >= 0.05 for x, y in rows.values())
    pooled = viewpoint_goals.paired_rounds_pooled([(vags[s], abl[s]) for s in SEEDS], 6, 10)
    clearing = pooled is not None and 100 * pooled[2] > S56_POOLED_CLEARING
    print("\n## The rule\n")
    print("| part | figure | met |")
    print("|---|---|---|")
    print(f"| (1) moving bins, after a move - direct, below -2.0 and beyond two standard errors | {diff:+.1f} ± {se:.1f} "
          f"| {'yes' if one else 'no'} |")
    successes = ", ".join(f"{100 * x['success']:.1f}" for x, _ in rows.values())
    margins = ", ".join(f"{100 * (x['success_6_10'] - y['success_6_10']):+.1f}" for x, y in rows.values())
    print(f"| (2a) VAGS success at least 85 % on every seed | {successes} | {'yes' if success else 'no'} |")
    print(f"| (2b) 6-10 margin at least +5 on every seed | {margins} | {'yes' if margin else 'no'} |")
    figure = "not paired" if pooled is None else f"{100 * pooled[2]:+.1f} ± {100 * pooled[3]:.1f}"
    print(f"| (2c) 6-10 clearing pooled over the seeds above the ablation's by more than s56's "
          f"{S56_POOLED_CLEARING:+.1f} | {figure} | {'yes' if clearing else 'no'} |")
    adopt = one and success and margin and clearing
    print(f"\nThe gpu preset {'takes' if adopt else 'does not take'} vags.success_label=clean.")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else os.path.join(HERE, "c56"))
