"""Prints the tables of driver.sh in this directory: each pipeline's wall clock (machine_log.txt)
and its stages' (timings.jsonl) with its compile-ahead children; f41's benchmark against issue 23's
goals (bench/viewpoint_goals.py); f41's Fig. 6 sweep, drawn to fig6.png beside this file when
matplotlib is installed.  Run from anywhere: python bench/results/viewpoints/default/thirtysecond_look/tables.py"""
import gzip
import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", "..", "..", "..", ".."))
RUNS = (("f41", "cold (empty cache)"), ("w42", "warm, --compile-ahead off"), ("w43", "warm, compile ahead (auto)"))


def timing_table():
    sys.path.insert(0, os.path.join(ROOT, "bench"))
    from pipeline_times import table
    print(table(HERE, RUNS))


def sweep_table():
    path = os.path.join(HERE, "f41", "sweep", "eval_vags_r20_sweep.json.gz")  # gzipped as committed
    if not os.path.exists(path):
        print("\nno sweep")
        return
    with gzip.open(path, "rt") as f:
        rows = json.load(f)["rows"]
    print("\n| threshold (rate gate's move value) | success % | clearing % | motion number | moves % | picks/h |")
    print("|---:|---:|---:|---:|---:|---:|")
    for r in sorted(rows, key=lambda r: r["threshold"]):
        o = r["overall"]
        print(f"| {r['threshold']:+.2f} | {100 * o['grasp_success_rate']:.1f} | {100 * o['clearing_rate']:.1f} | "
              f"{o['motion_number']:.2f} | {100 * o['viewpoint_rate']:.1f} | {o['picks_per_hour']:.0f} |")
    sys.path.insert(0, ROOT)
    try:
        from vags_jax.benchmark import reports
        reports.plot_sweep(rows, os.path.join(HERE, "fig6.png"), title="f41 (the gpu preset): grasp success vs threshold")
        print("\ndrew fig6.png")
    except ImportError as e:  # matplotlib missing
        print(f"\nno plot: {e}")


def main():
    timing_table()
    f41 = os.path.join(HERE, "f41")
    if os.path.isdir(os.path.join(f41, "seed11")):
        print()
        subprocess.run([sys.executable, os.path.join(ROOT, "bench", "viewpoint_goals.py"), f41], check=False)
    sweep_table()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
