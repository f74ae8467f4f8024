"""Does a branch's failure compound along a pile?  The sixth run's gate table measured twice with
the same piles and keys (``python -m vags_jax.stages.gate_measure --follow direct|moved``): once
the piles follow the direct grasps (the gate's table), once the grasps after a move (as rounds
that always move).  Per attempt along the pile, both branches' success on each follow's states;
for each close-view region ("seen", "map") measured (bench/RESULTS.md, "Viewpoints that pay,
sixteenth look").  Run from anywhere: python bench/results/viewpoints/default/sixth_run/follow/tables.py"""
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", ".."))
import report_tables as rt  # noqa: E402


def rows(folder):
    return np.load(os.path.join(HERE, folder, "gate_states.npz"))


def pct(x):
    return f"{100 * np.mean(x):.1f}" if np.size(x) else "-"


def per_attempt(region):
    follow = {"direct": rows(region), "moved": rows(region + "_follow")}
    print(f"\nclose_region={region}: success per attempt along the pile (states; direct %, after a move %)\n")
    print("| attempt | states, following direct | direct % | after a move % | objects | states, following moves "
          "| direct % | after a move % | objects |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    steps = int(max(d["attempt"].max() for d in follow.values())) + 1
    for t in list(range(steps)) + ["all"]:
        cells = []
        for d in follow.values():
            k = np.ones(d["attempt"].shape, bool) if t == "all" else d["attempt"] == t
            cells += [str(int(k.sum())), pct(d["direct_success"][k]), pct(d["moved_success"][k]),
                      f"{d['objects'][k].mean():.2f}" if k.any() else "-"]
        print(f"| {t} | " + " | ".join(cells) + " |")


def settled():
    """The first attempts with the piles settled 0.85 s (the preset) and 2.0 s (``settle2/``)."""
    print("\nThe same states along the pile, piles settled 0.85 s (seen/) and 2.0 s (settle2/): direct %, after a move %\n")
    print("| attempt | 0.85 s: states | direct % | after a move % | 2.0 s: states | direct % | after a move % |")
    print("|---:|---:|---:|---:|---:|---:|---:|")
    a, b = rows("seen"), rows("settle2")
    for t in [0, 1, 2, "1-7", "all"]:
        cells = []
        for d in (a, b):
            at = d["attempt"]
            k = (np.ones(at.shape, bool) if t == "all" else at >= 1 if t == "1-7" else at == t)
            cells += [str(int(k.sum())), pct(d["direct_success"][k]), pct(d["moved_success"][k])]
        print(f"| {t} | " + " | ".join(cells) + " |")


def benchmark():
    """close_region=map on seeds 11-13 beside its ablation; every attempt moved, seen and map."""
    rt.table("close_region=map (the split pick), groups 1-10 x 50 rounds",
             [(s, "split", p, rt.find(os.path.join(HERE, "map", f"seed{s}"), n)) for s in (11, 12, 13)
              for p, n in (("`--no-viewpoint`", "eval_vags-no-viewpoint"), ("VAGS", "eval_vags"))])
    rt.table("Every attempt moved (--threshold 9), seed 11, groups 1-10 x 20 rounds",
             [(11, "split", f"close_region={r}", rt.find(os.path.join(HERE, r), "always_r20")) for r in ("seen", "map")])


def settled_benchmark():
    """VAGS and its ablation on piles settled 2.0 s (``--set scene.settle_time=2.0``, evaluation
    only; ``../settled/``) beside the same networks and gate at the preset's 0.85 s (``../split/``)."""
    folders = {"0.85 s": os.path.join(HERE, "..", "split"), "2.0 s": os.path.join(HERE, "..", "settled")}
    cases, diffs = [], []
    for s in (11, 12, 13):
        diff = [s]
        for label, folder in folders.items():
            nv, vags = (rt.find(os.path.join(folder, f"seed{s}"), n) for n in ("eval_vags-no-viewpoint", "eval_vags"))
            cases += [(s, f"settled {label}", "`--no-viewpoint`", nv), (s, f"settled {label}", "VAGS", vags)]
            a, b = rt.row(vags), rt.row(nv)
            diff += [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
        diffs.append(diff)
    rt.table("The split pick, piles settled 0.85 s (the preset) and 2.0 s (evaluation only), groups 1-10 x 50 rounds",
             cases)
    rt.differences("VAGS minus its ablation, in points", ["0.85 s: success", "6-10 success", "6-10 clearing",
                                                          "2.0 s: success", "6-10 success", "6-10 clearing"], diffs)


def main():
    for region in ("seen", "map"):
        per_attempt(region)
    settled()
    benchmark()
    settled_benchmark()


if __name__ == "__main__":
    main()
