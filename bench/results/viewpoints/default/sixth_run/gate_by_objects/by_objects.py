#!/usr/bin/env python3
"""The rate gate's table of the sixth run split by the objects on the table (2026-11-27):
    python bench/results/viewpoints/default/sixth_run/gate_by_objects/by_objects.py
reads gate.json and gate_states.npz beside it (written by python -m vags_jax.stages.gate_measure)."""
import json
import os

import numpy as np

here = os.path.dirname(os.path.abspath(__file__))
d = np.load(os.path.join(here, "gate_states.npz"))
g = json.load(open(os.path.join(here, "gate.json")))
p, ds, ms, ob = d["p_direct"], d["direct_success"], d["moved_success"], d["objects"]
extra = d["moved_seconds"] - d["direct_seconds"]
b = np.searchsorted(np.asarray(g["edges"]), p, side="right")
moves = np.asarray(g["move_value"])[b] > 0
print(f"{len(p)} states, rate {g['rate']:.4f} picks/s, moving bins {np.nonzero(np.asarray(g['move_value']) > 0)[0]}")
print("| objects | states | gate moves % | direct % | moved % | direct % where it moves | moved % where it moves |")
print("|---|---:|---:|---:|---:|---:|---:|")
for lo, hi in ((1, 1), (2, 2), (3, 3), (4, 5), (6, 10)):
    m = (ob >= lo) & (ob <= hi)
    mm = m & moves
    print(f"| {lo if lo == hi else f'{lo}-{hi}'} | {m.sum()} | {100 * moves[m].mean():.1f} | {100 * ds[m].mean():.1f} | "
          f"{100 * ms[m].mean():.1f} | {100 * ds[mm].mean():.1f} | {100 * ms[mm].mean():.1f} |")
print("\nmove value per bin (moved - direct - rate * extra seconds), table split by objects:")
for name, sel in (("1 object", ob == 1), ("2 or more", ob > 1)):
    vals = [ms[(b == k) & sel].mean() - ds[(b == k) & sel].mean() - g["rate"] * extra[(b == k) & sel].mean()
            for k in range(len(g["states"]))]
    print(f"  {name}: " + " ".join(f"{v:+.3f}" for v in vals))
