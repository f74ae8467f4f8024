#!/usr/bin/env python3
"""The forty-second look's tables and its rule's verdict (driver.sh, fixed before the run): s57
(the gpu preset, seed 57) with and without vags.gate_min_z=2, against its ablation; and one VAGS
table alone timed as a whole process.  Written before the run; reads what the driver wrote under
RUN_DIR (default: this folder's s57/) and the folder beside it (vags_alone.txt).

    python bench/results/viewpoints/default/fortysecond_look/tables.py [RUN_DIR]

(0) No verdict on gate_min_z unless the run's table moves in a bin within two standard errors of 0.
(1) The gpu preset takes vags.gate_min_z=2 only if, of the 15 goal checks (five goals x seeds
    11-13, against the one ablation), VAGS with it meets strictly more than VAGS without.
"""
import os
import re
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


def goals_met(run, policy):
    """(checks met, checks measured) for ``policy`` against the ablation over SEEDS; None where a
    report is missing."""
    return viewpoint_goals.checks_met(run, policy, ABLATION, SEEDS)


def main(run):
    table = rate_gate.from_dict(rate_gate.read(run))
    moving = [k for k, v in enumerate(table.move_value) if v > 0]
    close = [k for k in rate_gate.close_bins(table) if table.move_value[k] > 0]
    print(f"## The gate table ({run}/gate.json)\n")
    print(rate_gate.describe(table))
    print(f"\nmoving bins {moving} of {len(table.move_value)}; moving bins within two standard errors of 0: {close}\n",
          flush=True)
    for policy in ("vags", "vags-z2"):
        if goals_met(run, policy) is None:
            continue
        print(f"### {policy} against {ABLATION}\n", flush=True)
        subprocess.run([sys.executable, os.path.join(ROOT, "bench/viewpoint_goals.py"), run, "--goals",
                        "--policies", policy, ABLATION], check=True)
        print()
    print("## The rule\n")
    plain, z2 = goals_met(run, "vags"), goals_met(run, "vags-z2")
    if not close:
        print("(0) the table moves in no bin within two standard errors of 0: vags.gate_min_z=2 plays the same "
              "decisions here, so there is no verdict on it; the option stays, off.")
    elif plain is None or z2 is None:
        print("(0) a report is missing: no verdict; the option stays, off.")
    else:
        print("| variant | goal checks met (of 15) |\n|---|---:|")
        print(f"| VAGS | {plain[0]} |\n| VAGS, vags.gate_min_z=2 | {z2[0]} |")
        adopt = z2[0] > plain[0]
        print(f"\n(1) {'met' if adopt else 'not met'}: the gpu preset {'takes' if adopt else 'does not take'} "
              "vags.gate_min_z=2.")
    alone = os.path.join(os.path.dirname(run.rstrip("/")), "vags_alone.txt")
    report = viewpoint_goals.read_report(os.path.join(run, "alone", "eval_vags.json"))
    if os.path.isfile(alone) and report is not None:
        with open(alone) as f:
            m = re.search(r"real\s+(\d+)m([\d.]+)s", f.read())
        whole = 60 * int(m.group(1)) + float(m.group(2)) if m else float("nan")
        print("\n## A VAGS table alone (issue 27)\n")
        print(f"whole process {whole:.1f} s (goal: at most 40 s); the table {report['wall_s']:.1f} s, "
              f"{report['compile']['seconds']:.1f} s of it on {report['compile']['loaded']} programs loaded and "
              f"{report['compile']['compiled']} compiled; before the first round {report['process_s']}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else os.path.join(HERE, "s57"))
