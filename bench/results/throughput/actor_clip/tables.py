"""Prints the tables for driver.sh in this directory: stage 1 of the `gpu` preset three ways per
training seed (41, 42), one after the other on one bare H200: as the preset trains (``t<S>/``,
the target network's pass at every update), with ``stage1.bootstrap=actor`` (``a<S>/``), and with
the actor's values clipped (``stage1.bootstrap_clip=true``, ``c<S>/``); each GDNet benchmarked
greedily (eval.py's gdnet policy, groups 1-10 x 50 rounds, seeds 11-13).  Ends with the verdict
of the rule in driver.sh's header.  The runs made were those of ../h100_finish/driver.sh (one bare
H100, t and c only; the actor without the clip was not trained again).  driver_control.sh (one
bare H100, 2026-12-06, 14:26-14:41 UTC) adds t, a and c on seeds 43 and 44 with its own rule,
printed last; those seeds render with the preset's Warp renderer, 41 and 42 with the ray caster.
Run from anywhere: python bench/results/throughput/actor_clip/tables.py"""
import json
import os

HERE = os.path.dirname(os.path.abspath(__file__))
SEEDS = (41, 42)  # driver.sh's rule (run as ../h100_finish/driver.sh, 2026-12-06)
CONTROL_SEEDS = (43, 44)  # driver_control.sh's rule, once its runs are here
MODES = (("t", "target network"), ("a", "actor"), ("c", "actor, clipped"))
EVAL_SEEDS = (11, 12, 13)
QUARTERS = ((0, 30), (30, 60), (60, 90), (90, 120))


def training(run):
    """Stage 1's speed and its success by quarter of its iterations (attempt-weighted)."""
    with open(os.path.join(HERE, run, "metrics.jsonl")) as f:
        m = [json.loads(line) for line in f if line.strip()]
    first_wall = m[0]["wall_s"]
    first_end = max(i for i, r in enumerate(m) if r["wall_s"] == first_wall)  # the first chunk's last row
    rate = sum(r["attempts"] for r in m[first_end + 1:]) / (m[-1]["wall_s"] - first_wall)

    def success(lo, hi):
        part = [r for r in m if lo <= r["iteration"] < hi]
        return 100 * sum(r["success_rate"] * r["attempts"] for r in part) / sum(r["attempts"] for r in part)

    q_max_10 = next((r["q_max"] for r in m if r["iteration"] == 10), float("nan"))
    return {"rate": rate, "quarters": [success(lo, hi) for lo, hi in QUARTERS], "q10": q_max_10}


def benchmark(run):
    """Mean over seeds 11-13 of (success %, 6-10 success %, clearing %), or None if not run."""
    out = []
    for s in EVAL_SEEDS:
        path = os.path.join(HERE, run, f"seed{s}", "eval_gdnet.json")
        if not os.path.exists(path):
            return None
        with open(path) as f:
            d = json.load(f)
        big = [v for v in d["groups_metrics"] if v["n_objects"] >= 6]
        o = d["overall"]
        out.append((100 * o["grasp_success_rate"],
                    100 * sum(v["successes"] for v in big) / sum(v["attempts"] for v in big),
                    100 * o["clearing_rate"]))
    return [sum(col) / len(col) for col in zip(*out)]


def main():
    print("Stage 1 (train.py --config gpu --stage gdnet; 512 worlds, 120 iterations)\n")
    print("| training seed | bootstrap | attempts/s after the first chunk | success % by quarter of iterations "
          "| largest Q at iteration 10 | benchmark success % | 6-10 % | clearing % |")
    print("|---:|---|---:|---|---:|---:|---:|---:|")
    tr, bm = {}, {}
    for s in SEEDS + CONTROL_SEEDS:
        for k, mode in MODES:
            run = f"{k}{s}"
            if not os.path.isdir(os.path.join(HERE, run)):  # h100_finish/driver.sh trained t and c only
                continue
            t, b = tr[run], bm[run] = training(run), benchmark(run)
            q = " / ".join(f"{x:.1f}" for x in t["quarters"])
            bench = " | ".join(f"{x:.1f}" for x in b) if b else "not run | | "
            print(f"| {s} | {mode} | {t['rate']:.0f} | {q} | {t['q10']:.2f} | {bench} |")

    print()
    for k, mode in MODES[1:]:
        if any(f"{k}{s}" not in tr for s in SEEDS):
            continue
        gaps = [[tr[f"{k}{s}"]["quarters"][i] - tr[f"t{s}"]["quarters"][i] for s in SEEDS] for i in range(4)]
        print(f"{mode} - target network, success by quarter, mean over seeds: "
              + " / ".join(f"{sum(g) / len(g):+.1f}" for g in gaps) + " points")
    # The rule: c's first two quarters each no more than 2 points below t's (mean over seeds), and
    # c's benchmark success no more than 1 point below t's on both seeds.
    first_two = [sum(tr[f"c{s}"]["quarters"][i] - tr[f"t{s}"]["quarters"][i] for s in SEEDS) / len(SEEDS)
                 for i in (0, 1)]
    if any(bm[f"{k}{s}"] is None for s in SEEDS for k in ("t", "c")):
        print("Verdict: cannot be applied (a benchmark is missing)")
        return 0
    bench_gap = [bm[f"c{s}"][0] - bm[f"t{s}"][0] for s in SEEDS]
    print("Clipped - target network, benchmark success per seed: " + ", ".join(f"{g:+.1f}" for g in bench_gap))
    met = min(first_two) >= -2.0 and min(bench_gap) >= -1.0
    print(f"Verdict: {'met' if met else 'not met'} (first two quarters "
          + " / ".join(f"{g:+.1f}" for g in first_two) + ")")
    control_verdict(tr, bm)
    return 0


def control_verdict(tr, bm):
    """driver_control.sh's rule: over seeds 43-44, a's first quarter at least 4 points below t's and
    c's first two quarters each no more than 2 below; over seeds 41-44, c's benchmark no more than 1
    point below t's on average."""
    runs = [f"{k}{s}" for s in CONTROL_SEEDS for k in ("t", "a", "c")]
    if any(r not in tr or bm[r] is None for r in runs):
        print("\ndriver_control.sh (seeds 43, 44): not run yet")
        return
    def gap(k, i, seeds):
        return sum(tr[f"{k}{s}"]["quarters"][i] - tr[f"t{s}"]["quarters"][i] for s in seeds) / len(seeds)
    slow = gap("a", 0, CONTROL_SEEDS)
    clipped = [gap("c", i, CONTROL_SEEDS) for i in (0, 1)]
    bench = sum(bm[f"c{s}"][0] - bm[f"t{s}"][0] for s in SEEDS + CONTROL_SEEDS) / len(SEEDS + CONTROL_SEEDS)
    removes = slow <= -4.0 and min(clipped) >= -2.0
    print(f"\ndriver_control.sh: actor - target, first quarter (43, 44): {slow:+.1f}; clipped - target, first two "
          f"quarters: " + " / ".join(f"{g:+.1f}" for g in clipped) + f"; clipped - target, benchmark (41-44): {bench:+.1f}")
    print(f"Verdict: the clip {'removes' if removes else 'is not shown to remove'} the slow start; "
          f"it {'keeps' if bench >= -1.0 else 'does not keep'} the GDNet")


if __name__ == "__main__":
    raise SystemExit(main())
