"""Prints the tables of driver.sh in this directory: each pipeline's wall clock (machine_log.txt),
its stages' wall clock and compiling (timings.jsonl), its compile-ahead children's status, and the
benchmark of the runs that were evaluated (groups 1-10 x 50 rounds, seeds 11-13); then the verdict
of the rule in driver.sh's header.  Run from anywhere: python bench/results/throughput/pipeline_warm/tables.py"""
import json
import os
import re

HERE = os.path.dirname(os.path.abspath(__file__))
RUNS = (("g39", "cold (empty cache)"), ("g40", "warm (g39's cache)"))
EVAL_SEEDS = (11, 12, 13)
E38_VAGS = 91.8  # the preset before forward_needed_only, same evaluation (../forward_needed/tables.py)
GOALS_S = {"g39": 540, "g40": 360}


def load_jsonl(path):
    with open(path) as f:
        return [json.loads(line) for line in f if line.strip()]


def wall_clocks():
    """{run: seconds of its train.py} from machine_log.txt."""
    with open(os.path.join(HERE, "machine_log.txt")) as f:
        return {m.group(1): int(m.group(2)) for m in re.finditer(r"^train_(g\d+) rc=0 (\d+) s", f.read(), re.M)}


def benchmark(run, policy):
    """Mean over seeds 11-13 of the overall success %, or None if a seed is missing."""
    got = []
    for s in EVAL_SEEDS:
        path = os.path.join(HERE, run, f"seed{s}", f"eval_{policy}.json")
        if not os.path.exists(path):
            return None
        got.append(100 * json.load(open(path))["overall"]["grasp_success_rate"])
    return sum(got) / len(got)


def main():
    walls = wall_clocks()
    print("| run | train.py s | stage 1 s | stage 2 s | stage 3 s | gate table s | XLA compiling s (stages + table) "
          "| compile ahead: stage 2 / gate table | VAGS % | ablation % |")
    print("|---|---:|---:|---:|---:|---:|---:|---|---:|---:|")
    ok = True
    for run, name in RUNS:
        rows = {r["stage"]: r for r in load_jsonl(os.path.join(HERE, run, "timings.jsonl"))}
        compiling = sum(rows[s]["compile"]["seconds"] for s in ("stage1", "stage2", "stage3", "gate"))
        ahead = " / ".join(f"{rows[k]['status']}, {rows[k]['compile']['compiled']} compiled, "
                           f"{rows[k]['compile']['loaded']} loaded" + (", out of memory" if rows[k].get("out_of_memory") else "")
                           for k in ("compile_ahead", "compile_ahead_gate"))
        v, a = benchmark(run, "vags"), benchmark(run, "vags-no-viewpoint")
        print(f"| {run}, {name} | {walls.get(run, '')} | " + " | ".join(f"{rows[s]['wall_s']:.1f}" for s in ("stage1", "stage2", "stage3", "gate"))
              + f" | {compiling:.1f} | {ahead} | " + (f"{v:.1f}" if v is not None else "not run") + " | "
              + (f"{a:.1f}" if a is not None else "not run") + " |")
        ok &= walls.get(run, 10**9) < GOALS_S[run]
        ok &= all(rows[k]["status"] == "done" and not rows[k].get("out_of_memory") for k in ("compile_ahead", "compile_ahead_gate"))
    v = benchmark("g40", "vags")
    if v is None:
        print("\nVerdict: not decided (the warm run's benchmark is missing)")
        return 0
    ok &= abs(v - E38_VAGS) <= 2
    print(f"\nwarm run's VAGS {v:.1f} % against e38's {E38_VAGS} %: {v - E38_VAGS:+.1f} points")
    print(f"Verdict: {'met' if ok else 'not met'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
