"""Prints the tables of bench/RESULTS.md, "Stage 1 with the actor's bootstrap value": three
pairs of stage-1 trainings of the `gpu` preset (training seeds 21, 22, 23), each as the preset
trains (``t<S>/``: the target network's pass at every update) and with ``stage1.bootstrap=actor``
(``a<S>/``), one after the other on one bare H200 (``driver.sh``, ``machine_log.txt``); each
GDNet benchmarked greedily (eval.py's gdnet policy, groups 1-10 x 50 rounds, seeds 11-13); and
bench/train_throughput.py's breakdown of one iteration, both ways (``tp_*.json``).
Run from anywhere: python bench/results/throughput/actor_bootstrap/tables.py"""
import json
import os

HERE = os.path.dirname(os.path.abspath(__file__))
SEEDS = (21, 22, 23)
EVAL_SEEDS = (11, 12, 13)
QUARTERS = ((0, 30), (30, 60), (60, 90), (90, 120))


def rows(run):
    with open(os.path.join(HERE, run, "metrics.jsonl")) as f:
        return [json.loads(line) for line in f if line.strip()]


def training(run):
    """Stage 1's speed and its success by quarter of its iterations (attempt-weighted)."""
    m = rows(run)
    with open(os.path.join(HERE, run, "timings.jsonl")) as f:
        timing = json.loads(f.readline())
    first_wall = m[0]["wall_s"]
    first_end = max(i for i, r in enumerate(m) if r["wall_s"] == first_wall)  # the first chunk's last row
    after = m[first_end + 1:]
    attempts = sum(r["attempts"] for r in after)
    rate = attempts / (m[-1]["wall_s"] - first_wall)

    def success(lo, hi):
        part = [r for r in m if lo <= r["iteration"] < hi]
        return 100 * sum(r["success_rate"] * r["attempts"] for r in part) / sum(r["attempts"] for r in part)

    return {"wall": timing["wall_s"], "compile": timing["compile"]["seconds"], "attempts": int(m[-1]["attempts_total"]),
            "rate": rate, "quarters": [success(lo, hi) for lo, hi in QUARTERS], "all": success(0, len(m))}


def benchmark(run):
    out = []
    for s in EVAL_SEEDS:
        with open(os.path.join(HERE, run, f"seed{s}", "eval_gdnet.json")) as f:
            d = json.load(f)
        big = [v for v in d["groups_metrics"] if v["n_objects"] >= 6]
        six = 100 * sum(v["successes"] for v in big) / sum(v["attempts"] for v in big)
        o = d["overall"]
        out.append((100 * o["grasp_success_rate"], six, 100 * o["clearing_rate"], o["motion_number"]))
    return out


def mean(xs):
    return sum(xs) / len(xs)


def main():
    print("Stage 1 (train.py --config gpu --stage gdnet; 512 worlds, 120 iterations)\n")
    print("| training seed | bootstrap | stage wall s | compiling s | attempts | attempts/s after the first chunk "
          "| success % by quarter of iterations | success % over the stage |")
    print("|---:|---|---:|---:|---:|---:|---|---:|")
    tr = {}
    for s in SEEDS:
        for mode, run in (("target network", f"t{s}"), ("actor", f"a{s}")):
            t = tr[run] = training(run)
            q = " / ".join(f"{x:.1f}" for x in t["quarters"])
            print(f"| {s} | {mode} | {t['wall']:.1f} | {t['compile']:.1f} | {t['attempts']:,} | {t['rate']:.0f} | {q} "
                  f"| {t['all']:.1f} |")
    print("\nRatio of attempts/s (actor / target network), per pair: "
          + ", ".join(f"{tr[f'a{s}']['rate'] / tr[f't{s}']['rate']:.2f}x" for s in SEEDS))

    print("\nGDNet greedy on the benchmark (eval.py, groups 1-10 x 50 rounds)\n")
    print("| training seed | bootstrap | success % (seeds 11 / 12 / 13) | mean | 6-10 success % mean "
          "| clearing % mean | motion number mean |")
    print("|---:|---|---|---:|---:|---:|---:|")
    bm = {}
    for s in SEEDS:
        for mode, run in (("target network", f"t{s}"), ("actor", f"a{s}")):
            b = bm[run] = benchmark(run)
            print(f"| {s} | {mode} | {' / '.join(f'{x[0]:.1f}' for x in b)} | {mean([x[0] for x in b]):.1f} "
                  f"| {mean([x[1] for x in b]):.1f} | {mean([x[2] for x in b]):.1f} | {mean([x[3] for x in b]):.3f} |")
    print("\nActor minus target network, benchmark success (mean of seeds 11-13), per pair: "
          + ", ".join(f"{mean([x[0] for x in bm[f'a{s}']]) - mean([x[0] for x in bm[f't{s}']]):+.1f}" for s in SEEDS))

    print("\nOne iteration (bench/train_throughput.py --config gpu --trunks small --no-parts; ms)\n")
    tp = {m: json.load(open(os.path.join(HERE, f"tp_{m}.json"))) for m in ("target", "actor")}
    keys = ("forward_and_choice_s", "physics_s", "render_heightmaps_s", "replay_add_s", "replay_sample_s",
            "updates_s", "rest_of_iteration_s")
    print("| bootstrap | attempts/s | iteration | " + " | ".join(k[:-2].replace("_", " ") for k in keys)
          + " | one update | update MFU |")
    print("|---|---:|---:|" + "---:|" * (len(keys) + 2))
    for m in ("target", "actor"):
        d = tp[m]
        u = d["update_mfu"][0]
        print(f"| {m} | {d['attempts_per_s']:.0f} | {1e3 * d['iteration_s']:.1f} | "
              + " | ".join(f"{1e3 * d['phases'][k]:.1f}" for k in keys)
              + f" | {1e3 * u['update_s']:.2f} | {100 * u['mfu']:.1f} % |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
