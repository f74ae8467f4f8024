"""What gating by p_direct could add at most on 6-10 objects, read from the per-state rows of two
gate tables of the sixth run (bench/RESULTS.md, "Viewpoints that pay, fifteenth look"): on the
table's states with 6-10 objects, success when the states with the lowest p_direct (a share q)
take the grasp after a move and the rest the direct grasp; and the per-state best of the two
branches, a ceiling inflated by the outcomes' own noise.
Run from anywhere: python bench/results/viewpoints/default/sixth_run/gate_ceiling.py"""
import os

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
TABLES = {"stage 3's networks (gate_by_objects/)": "gate_by_objects",
          "stage 2's networks (stage2_networks/)": "stage2_networks"}


def main():
    print("| networks | 6-10 states | direct % | " + " | ".join(f"move lowest {q} %" for q in (10, 15, 20, 30, 50, 100))
          + " | per-state best % |")
    print("|---|---:|---:|" + "---:|" * 7)
    for label, folder in TABLES.items():
        d = np.load(os.path.join(HERE, folder, "gate_states.npz"))
        big = d["objects"] >= 6
        order = np.argsort(d["p_direct"][big])
        direct = d["direct_success"][big][order].astype(float)
        moved = d["moved_success"][big][order].astype(float)
        cells = []
        for q in (0.10, 0.15, 0.20, 0.30, 0.50, 1.00):
            k = int(q * direct.size)
            s = np.concatenate([moved[:k], direct[k:]]).mean()
            cells.append(f"{100 * s:.1f} ({100 * (s - direct.mean()):+.1f})")
        print(f"| {label} | {direct.size} | {100 * direct.mean():.1f} | " + " | ".join(cells)
              + f" | {100 * np.maximum(direct, moved).mean():.1f} |")


if __name__ == "__main__":
    main()
