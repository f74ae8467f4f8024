"""Prints the tables of driver.sh in this directory once its runs are here: the whole `gpu` pipeline
as it is (``p<S>/``) and with stage 1's clipped actor values (``c<S>/``: stage1.bootstrap=actor
stage1.bootstrap_clip=true), seeds 36 and 37 on one GPU, each benchmarked as VAGS and its
ablation (groups 1-10 x 50 rounds, seeds 11-13); then the verdict of the rule in driver.sh's header.
Run from anywhere: python bench/results/throughput/pipeline_clip/tables.py"""
import json
import os

HERE = os.path.dirname(os.path.abspath(__file__))
PAIRS = ((36, "p36", "c36"), (37, "p37", "c37"))
SPEED_PAIR = 36  # c36 compiles from an empty cache, p36 after it (driver.sh's header)
EVAL_SEEDS = (11, 12, 13)


def load_jsonl(path):
    with open(path) as f:
        return [json.loads(line) for line in f if line.strip()]


def process_seconds(run):
    """train.py's process wall clock from the machine log, or None."""
    log = os.path.join(HERE, "machine_log_pipeline.txt")
    if not os.path.exists(log):
        return None
    secs = [int(line.split()[2]) for line in open(log) if line.startswith(f"train_{run} rc=0 ")]
    return secs[-1] if secs else None


def peak_gib(run):
    """Peak device memory from train.py's --json line in its log, or None."""
    log = os.path.join(HERE, f"train_{run}.txt")
    if not os.path.exists(log):
        return None
    peaks = [json.loads(line)["peak_device_gib"] for line in open(log)
             if line.startswith("{") and '"peak_device_gib"' in line]
    return peaks[-1] if peaks else None


def training(run):
    """Stage 1's attempts/s after its first chunk and its first-quarter success; the pipeline's wall."""
    m = load_jsonl(os.path.join(HERE, run, "metrics.jsonl"))
    first_wall = m[0]["wall_s"]
    first_end = max(i for i, r in enumerate(m) if r["wall_s"] == first_wall)
    rate = sum(r["attempts"] for r in m[first_end + 1:]) / (m[-1]["wall_s"] - first_wall)
    part = [r for r in m if r["iteration"] < 30]
    first_q = 100 * sum(r["success_rate"] * r["attempts"] for r in part) / sum(r["attempts"] for r in part)
    summary = json.load(open(os.path.join(HERE, run, "summary.json")))
    return {"rate": rate, "first_quarter": first_q, "wall": summary["wall_s"], "process": process_seconds(run),
            "peak": peak_gib(run)}


def benchmark(run, policy):
    """Mean over seeds 11-13 of (success %, 6-10 success %, motion number), or None if any is missing."""
    rows = []
    for s in EVAL_SEEDS:
        path = os.path.join(HERE, run, f"seed{s}", f"eval_{policy}.json")
        if not os.path.exists(path):
            return None
        d = json.load(open(path))
        big = [v for v in d["groups_metrics"] if v["n_objects"] >= 6]
        rows.append((100 * d["overall"]["grasp_success_rate"],
                     100 * sum(v["successes"] for v in big) / sum(v["attempts"] for v in big),
                     d["overall"]["motion_number"]))
    return [sum(c) / len(c) for c in zip(*rows)]


def main():
    runs = [r for _, p, c in PAIRS for r in (p, c)]
    missing = [r for r in runs if not os.path.exists(os.path.join(HERE, r, "summary.json"))]
    if len(missing) == len(runs):
        print("driver.sh has not run (no run's summary is here)")
        return 0
    runs = [r for r in runs if r not in missing]
    tr = {r: training(r) for r in runs}
    bm = {(r, k): benchmark(r, k) for r in runs for k in ("vags", "vags-no-viewpoint")}
    print("| training seed | pipeline | train.py process s | pipeline wall s | stage-1 attempts/s | stage-1 first quarter % "
          "| peak GiB | VAGS % | VAGS 6-10 % | motions | ablation % | ablation 6-10 % |")
    print("|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for seed, p, c in PAIRS:
        for r, name in ((p, "preset"), (c, "clipped actor")):
            if r in missing:
                print(f"| {seed} | {name} | not trained | | | | | | | | | |")
                continue
            t, v, a = tr[r], bm[r, "vags"], bm[r, "vags-no-viewpoint"]
            bench = (f"{v[0]:.1f} | {v[1]:.1f} | {v[2]:.3f}" if v else "not run | | ") + " | " + \
                    (f"{a[0]:.1f} | {a[1]:.1f}" if a else "not run | ")
            print(f"| {seed} | {name} | {t['process']} | {t['wall']:.1f} | {t['rate']:.0f} | {t['first_quarter']:.1f} "
                  f"| {t['peak']} | {bench} |")
    done = [(seed, p, c) for seed, p, c in PAIRS
            if all(r in tr and bm[r, k] is not None for r in (p, c) for k in ("vags", "vags-no-viewpoint"))]

    def gap(f):
        return sum(f(c) - f(p) for _, p, c in done) / len(done) if done else float("nan")

    vags = gap(lambda r: bm[r, "vags"][0])
    abl = gap(lambda r: bm[r, "vags-no-viewpoint"][0])
    first = gap(lambda r: tr[r]["first_quarter"])
    _, p, c = next(x for x in PAIRS if x[0] == SPEED_PAIR)
    secs = (tr.get(c, {}).get("process"), tr.get(p, {}).get("process"))
    faster = None if None in secs else secs[0] < secs[1]
    pairs = ", ".join(str(seed) for seed, _, _ in done) or "none"
    print(f"\nclipped - preset, mean over the pairs benchmarked ({pairs}): VAGS {vags:+.2f}, ablation {abl:+.2f}, "
          f"stage 1's first quarter {first:+.2f} points; train.py on pair {SPEED_PAIR}: {secs[0]} against {secs[1]} s")
    if faster is False:  # one criterion failed: the rule cannot be met whatever the other pair gives
        print(f"Verdict: not met (train.py on pair {SPEED_PAIR} is not faster with the clip)")
    elif len(done) < len(PAIRS):
        print("Verdict: not yet decided (a pair is missing)")
    else:
        met = vags >= -1.0 and abl >= -1.0 and first >= -2.0 and faster is True
        print(f"Verdict: {'met' if met else 'not met'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
