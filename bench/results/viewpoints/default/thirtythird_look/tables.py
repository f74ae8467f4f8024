"""Prints the tables of driver.sh in this directory: each pipeline's wall clock (machine_log.txt)
and its stages' (timings.jsonl) with its compile-ahead children; f44's same-states table
(bench/gate_headroom.py's headroom.json); the one-object states of f44's and f41's gate tables,
fresh piles of one object against the last object of a pile; the benchmark's one-object rounds
of f41 and f44, VAGS against its ablation on the same scenes; f44's benchmark against issue 23's
goals (bench/viewpoint_goals.py).  Run from anywhere: python bench/results/viewpoints/default/thirtythird_look/tables.py"""
import gzip
import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", "..", "..", "..", ".."))
RUNS = (("f44", "cold (empty cache)"), ("w45", "warm, compile ahead (auto)"), ("w46", "warm, --compile-ahead off"))


def timing_table():
    sys.path.insert(0, os.path.join(ROOT, "bench"))
    from pipeline_times import table
    print(table(HERE, RUNS))


def headroom_table():
    path = os.path.join(HERE, "f44", "headroom.json")
    if not os.path.exists(path):
        print("\nno headroom table")
        return
    with open(path) as f:
        got = json.load(f)
    sys.path.insert(0, os.path.join(ROOT, "bench"))
    from gate_headroom import table
    print(f"\nf44's gate table states ({got['measure']['live_states']} live; GDNets {got['gdnet_pick']}; moving bins "
          f"{got['moving_bins']['moving_bins']} of {got['moving_bins']['bins']}; outcomes equal to the run's table: "
          f"{got['agreement_with_run_table']}; {got['measure']['wall_s']} s on {got['device']})\n")
    print(table(got["summary"]))


def one_object_states():
    """The gate tables' one-object states: a fresh pile of one (attempt 0) or the last object of a
    pile; how often the table moves there, and both branches' success."""
    import numpy as np

    print("\n| run | one-object states | n | the table moves % | direct % | after a move % | in its moving bins: n | direct % | after a move % |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|")
    for run, path in (("f44", os.path.join(HERE, "f44")), ("f41", os.path.join(HERE, "..", "thirtysecond_look", "f41"))):
        s = np.load(os.path.join(path, "gate_states.npz"))
        with open(os.path.join(path, "gate.json")) as f:
            g = json.load(f)
        moves = (np.asarray(g["move_value"]) > 0)[np.searchsorted(np.asarray(g["edges"]), s["p_direct"], side="right")]
        one = s["objects"] == 1
        for name, m in (("fresh pile of one", one & (s["attempt"] == 0)), ("last of a pile", one & (s["attempt"] > 0))):
            pct = lambda x: f"{100 * np.mean(x):.1f}" if x.size else "-"  # noqa: E731
            mm = m & moves
            print(f"| {run} | {name} | {m.sum()} | {pct(moves[m])} | {pct(s['direct_success'][m])} | "
                  f"{pct(s['moved_success'][m])} | {mm.sum()} | {pct(s['direct_success'][mm])} | {pct(s['moved_success'][mm])} |")


def _report(path):
    """A report as eval.py wrote it, or gzipped beside (as committed)."""
    if os.path.exists(path):
        with open(path) as f:
            return json.load(f)
    with gzip.open(path + ".gz", "rt") as f:
        return json.load(f)


def one_object_rounds():
    """Per run, over seeds 11-13: the one-object rounds where VAGS moved the camera, those the
    ablation did not clear at its first attempt, how many of those VAGS moved on, and those
    VAGS did not clear at its first attempt (the reports' per-round outcomes)."""
    print("\n| run | rounds where VAGS moved | rounds the ablation did not clear on its first attempt "
          "| of those, rounds where VAGS moved | rounds VAGS did not clear on its first attempt |")
    print("|---|---:|---:|---:|---:|")
    dirs = (("f41", os.path.join(HERE, "..", "seed{s}")), ("f44", os.path.join(HERE, "f44", "seed{s}")))
    for run, pattern in dirs:
        moved = failed = caught = vags_failed = 0
        for seed in (11, 12, 13):
            d = pattern.format(s=seed)
            v = _report(os.path.join(d, "eval_vags.json"))["outcomes"]["1"]
            a = _report(os.path.join(d, "eval_vags-no-viewpoint.json"))["outcomes"]["1"]
            m = {i for i, (n, t) in enumerate(zip(v["motions"], v["attempts"])) if n > t}
            f = {i for i, (t, ok) in enumerate(zip(a["attempts"], a["successes"])) if t > 1 or ok < 1}
            moved, failed, caught = moved + len(m), failed + len(f), caught + len(f & m)
            vags_failed += sum(1 for t, ok in zip(v["attempts"], v["successes"]) if t > 1 or ok < 1)
        print(f"| {run} | {moved} | {failed} | {caught} | {vags_failed} |")


def main():
    timing_table()
    headroom_table()
    one_object_states()
    one_object_rounds()
    f44 = os.path.join(HERE, "f44")
    if os.path.isdir(os.path.join(f44, "seed11")):
        print()
        subprocess.run([sys.executable, os.path.join(ROOT, "bench", "viewpoint_goals.py"), f44], check=False)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
