"""Prints the tables of driver.sh in this directory once its runs are here: the whole `gpu` pipeline
as it is (``e38/``) and with ``net.forward_needed_only=true`` (``n38/``), the same seed on one GPU:
each stage's milliseconds per iteration after its first chunk (no compiling in them), stage 1's success by
quarter, and each run's VAGS and ablation (groups 1-10 x 50 rounds, seeds 11-13); then the verdict
of the rule in driver.sh's header.  Run from anywhere: python bench/results/throughput/forward_needed/tables.py"""
import json
import os

HERE = os.path.dirname(os.path.abspath(__file__))
RUNS = (("e38", "preset"), ("n38", "forward_needed_only"))
STAGES = (("stage1", "metrics.jsonl"), ("stage2", "stage2_metrics.jsonl"), ("stage3", "stage3_metrics.jsonl"))
EVAL_SEEDS = (11, 12, 13)
CHUNK_GAP = 1.0  # s: rows closer than this in wall_s belong to one chunk


def load_jsonl(path):
    with open(path) as f:
        return [json.loads(line) for line in f if line.strip()]


def after_first_chunk(rows):
    """Milliseconds per iteration after the stage's first chunk, and the attempts/s over them, or
    None (one chunk).  A row's wall_s is the stage's clock at the end of its chunk, the same for
    the chunk's rows (chunks may differ in length)."""
    first = first_chunk_end(rows)
    later = [r for r in rows if r["wall_s"] > first + CHUNK_GAP]
    if not later:
        return None
    secs = max(r["wall_s"] for r in rows) - first
    return 1000 * secs / len(later), sum(r["attempts"] for r in later) / secs


def first_chunk_end(rows):
    """The stage's clock at the end of its first chunk: the rows of one chunk are written within
    a fraction of a second of each other (not always at one clock reading), chunks seconds apart."""
    end = rows[0]["wall_s"]
    for r in rows[1:]:
        if r["wall_s"] > end + CHUNK_GAP:
            break
        end = r["wall_s"]
    return end


def iterations_after_first_chunk(run, stage):
    """Iterations of ``stage`` after its first chunk in ``run``."""
    rows = load_jsonl(os.path.join(HERE, run, dict(STAGES)[stage]))
    first = first_chunk_end(rows)
    return sum(1 for r in rows if r["wall_s"] > first + CHUNK_GAP)


def quarters(rows):
    """Stage 1's success % in each quarter of its iterations (attempt-weighted)."""
    n = max(r["iteration"] for r in rows) + 1
    out = []
    for q in range(4):
        part = [r for r in rows if q * n // 4 <= r["iteration"] < (q + 1) * n // 4]
        out.append(100 * sum(r["success_rate"] * r["attempts"] for r in part) / sum(r["attempts"] for r in part))
    return out


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
    runs = [(r, name) for r, name in RUNS if os.path.exists(os.path.join(HERE, r, "metrics.jsonl"))]
    if not runs:
        print("driver.sh has not run (no run's metrics are here)")
        return 0
    speed = {}
    print("| run | stage | chunks | ms per iteration after the first chunk | attempts/s after the first chunk |")
    print("|---|---|---:|---:|---:|")
    for r, name in runs:
        for stage, f in STAGES:
            path = os.path.join(HERE, r, f)
            if not os.path.exists(path):
                continue
            rows = load_jsonl(path)
            got = after_first_chunk(rows)
            speed[r, stage] = got
            n = 1 + sum(1 for a, b in zip(rows, rows[1:]) if b["wall_s"] > a["wall_s"] + CHUNK_GAP)
            print(f"| {name} | {stage} | {n} | " + (f"{got[0]:.1f} | {got[1]:.0f} |" if got else "| |"))
    print("\n| run | stage 1 success % by quarter | VAGS % | VAGS 6-10 % | motions | ablation % | ablation 6-10 % |")
    print("|---|---|---:|---:|---:|---:|---:|")
    bm = {}
    for r, name in runs:
        q = " / ".join(f"{x:.1f}" for x in quarters(load_jsonl(os.path.join(HERE, r, "metrics.jsonl"))))
        v, a = benchmark(r, "vags"), benchmark(r, "vags-no-viewpoint")
        bm[r] = (v, a)
        bench = (f"{v[0]:.1f} | {v[1]:.1f} | {v[2]:.3f}" if v else "not run | | ") + " | " + \
                (f"{a[0]:.1f} | {a[1]:.1f}" if a else "not run | ")
        print(f"| {name} | {q} | {bench} |")
    (e, _), (n, _) = RUNS
    need = [(e, "stage1"), (n, "stage1")]
    if any(speed.get(k) is None for k in need) or any(x is None for r in (e, n) for x in bm.get(r, (None, None))):
        print("\nVerdict: not yet decided (a run or an evaluation is missing)")
        return 0
    faster = speed[n, "stage1"][0] < speed[e, "stage1"][0]
    later = {r: sum(speed[r, st][0] * iterations_after_first_chunk(r, st) for st in ("stage2", "stage3")
                    if speed.get((r, st))) for r in (e, n)}
    faster = faster and later[n] <= later[e]
    dv, da = bm[n][0][0] - bm[e][0][0], bm[n][1][0] - bm[e][1][0]
    print(f"\nforward_needed_only - preset: stage 1 {speed[n, 'stage1'][0]:.1f} against {speed[e, 'stage1'][0]:.1f} ms "
          f"an iteration; stages 2 and 3 after their first chunks {later[n] / 1000:.1f} against {later[e] / 1000:.1f} s; "
          f"VAGS {dv:+.1f}, ablation {da:+.1f} points")
    print(f"Verdict: {'met' if faster and abs(dv) <= 2 and abs(da) <= 2 else 'not met'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
