"""Prints the tables of bench/RESULTS.md, "The whole gpu pipeline with the actor's bootstrap value
and the Warp renderer": train.py --config gpu as it is (``t<S>/``, GPU 0) and with
``stage1.bootstrap=actor camera.renderer=warp camera.render_batch=512`` (``a<S>/``, GPU 1), side by
side on one bare 2 x H200 host, training seeds 31 and 32 (``driver.sh``, ``machine_log.txt``) and 33
(``seed33/``, run after the rule's two pairs with the machine time left); each run benchmarked as
VAGS and its ablation (groups 1-10 x 50 rounds, seeds 11-13); and bench/train_throughput.py's
breakdown of a stage-1 iteration (``tp_*.json``) and of stage 3 (``tp_stage3_t31.json``).
Run from anywhere: python bench/results/throughput/pipeline_actor_warp/tables.py"""
import json
import os

HERE = os.path.dirname(os.path.abspath(__file__))
RUNS = (("31", "t31", "a31"), ("32", "t32", "a32"), ("33", "seed33/t33", "seed33/a33"))
RULE_PAIRS = ("31", "32")
EVAL_SEEDS = (11, 12, 13)
QUARTERS = ((0, 30), (30, 60), (60, 90), (90, 120))


def load_jsonl(path):
    with open(path) as f:
        return [json.loads(line) for line in f if line.strip()]


def machine_seconds(run):
    """train.py's process wall clock from the driver's log (imports and checks included)."""
    base = os.path.dirname(run)
    name = os.path.basename(run)
    for line in open(os.path.join(HERE, base, "machine_log.txt")):
        if line.startswith(f"train_{name} "):
            return int(line.split()[2])
    raise KeyError(run)


def training(run):
    summary = json.load(open(os.path.join(HERE, run, "summary.json")))
    stages = {s["stage"]: s for s in summary["stages"]}
    timing = {t["stage"]: t for t in load_jsonl(os.path.join(HERE, run, "timings.jsonl"))}
    m = load_jsonl(os.path.join(HERE, run, "metrics.jsonl"))
    first_wall = m[0]["wall_s"]
    first_end = max(i for i, r in enumerate(m) if r["wall_s"] == first_wall)
    after = m[first_end + 1:]
    rate = sum(r["attempts"] for r in after) / (m[-1]["wall_s"] - first_wall)

    def success(rows, lo, hi):
        part = [r for r in rows if lo <= r["iteration"] < hi]
        return 100 * sum(r["success_rate"] * r["attempts"] for r in part) / sum(r["attempts"] for r in part)

    return {"process": machine_seconds(run), "wall": summary["wall_s"],
            "stage": {k: stages[k]["wall_s"] for k in ("stage1", "stage2", "stage3", "gate")},
            "compile1": timing["stage1"]["compile"]["seconds"], "rate": rate,
            "quarters": [success(m, lo, hi) for lo, hi in QUARTERS],
            "recent": {k: 100 * stages[k]["recent_success_rate"] for k in ("stage1", "stage2", "stage3")},
            "gate": stages["gate"]}


def benchmark(run, policy):
    out = []
    for s in EVAL_SEEDS:
        d = json.load(open(os.path.join(HERE, run, f"seed{s}", f"eval_{policy}.json")))
        big = [v for v in d["groups_metrics"] if v["n_objects"] >= 6]
        six = 100 * sum(v["successes"] for v in big) / sum(v["attempts"] for v in big)
        o = d["overall"]
        out.append({"success": 100 * o["grasp_success_rate"], "six": six, "clearing": 100 * o["clearing_rate"],
                    "motion": o["motion_number"], "eval_wall": d["wall_s"]})
    return out


def mean(xs):
    xs = list(xs)
    return sum(xs) / len(xs)


def slash(evals):
    return " / ".join(f"{x['success']:.1f}" for x in evals)


def label(run):
    return "actor + Warp renderer" if os.path.basename(run).startswith("a") else "preset"


def main():
    tr = {r: training(r) for _, t, a in RUNS for r in (t, a)}
    print("The pipeline (train.py --config gpu; GPU 0 the preset, GPU 1 the three settings; seconds)\n")
    print("| training seed | pipeline | caches | train.py process | pipeline wall (summary) | stage 1 | stage 2 "
          "| stage 3 | gate table | stage-1 compiling |")
    print("|---:|---|---|---:|---:|---:|---:|---:|---:|---:|")
    for seed, t, a in RUNS:
        for r in (t, a):
            x = tr[r]
            cache = "cold" if seed == "31" else "warm"
            print(f"| {seed} | {label(r)} | {cache} | {x['process']} | {x['wall']:.1f} | {x['stage']['stage1']:.1f} "
                  f"| {x['stage']['stage2']:.1f} | {x['stage']['stage3']:.1f} | {x['stage']['gate']:.1f} "
                  f"| {x['compile1']:.1f} |")
    print("\nProcess wall clock, new / preset, per pair: "
          + ", ".join(f"{tr[a]['process'] / tr[t]['process']:.2f}" for _, t, a in RUNS))

    print("\nStage 1 and the training success\n")
    print("| training seed | pipeline | stage-1 attempts/s after its first chunk | stage-1 success % by quarter "
          "| stage 1 / 2 / 3 recent success % | gate: moving bins, GDNet |")
    print("|---:|---|---:|---|---|---|")
    for seed, t, a in RUNS:
        for r in (t, a):
            x = tr[r]
            q = " / ".join(f"{v:.1f}" for v in x["quarters"])
            rec = " / ".join(f"{x['recent'][k]:.1f}" for k in ("stage1", "stage2", "stage3"))
            g = x["gate"]
            print(f"| {seed} | {label(r)} | {x['rate']:.0f} | {q} | {rec} | {g['moving_bins']}, "
                  f"{g['gdnet']} / {g['close_gdnet']} |")

    print("\nThe benchmark (eval.py, groups 1-10 x 50 rounds, seeds 11 / 12 / 13)\n")
    print("| training seed | pipeline | VAGS success % | mean | 6-10 mean | motion number mean | clearing % mean "
          "| ablation success % | mean | 6-10 mean | VAGS - ablation, 6-10 |")
    print("|---:|---|---|---:|---:|---:|---:|---|---:|---:|---:|")
    bm = {}
    for seed, t, a in RUNS:
        for r in (t, a):
            v = bm[r, "vags"] = benchmark(r, "vags")
            b = bm[r, "abl"] = benchmark(r, "vags-no-viewpoint")
            print(f"| {seed} | {label(r)} | {slash(v)} "
                  f"| {mean(x['success'] for x in v):.1f} | {mean(x['six'] for x in v):.1f} "
                  f"| {mean(x['motion'] for x in v):.3f} | {mean(x['clearing'] for x in v):.1f} "
                  f"| {slash(b)} | {mean(x['success'] for x in b):.1f} "
                  f"| {mean(x['six'] for x in b):.1f} | {mean(x['six'] for x in v) - mean(x['six'] for x in b):+.1f} |")
    for pairs, name in ((RULE_PAIRS, "the rule's pairs (31, 32)"), (tuple(s for s, _, _ in RUNS), "all three pairs")):
        sel = [(t, a) for s, t, a in RUNS if s in pairs]
        pre = mean(x["success"] for t, _ in sel for x in bm[t, "vags"])
        new = mean(x["success"] for _, a in sel for x in bm[a, "vags"])
        print(f"\nVAGS success over {name} and seeds 11-13: preset {pre:.2f} %, new {new:.2f} % ({new - pre:+.2f} points)")
    print("Per pair, new - preset VAGS success: "
          + ", ".join(f"{mean(x['success'] for x in bm[a, 'vags']) - mean(x['success'] for x in bm[t, 'vags']):+.1f}"
                      for _, t, a in RUNS))
    print("Per pair, new - preset ablation success: "
          + ", ".join(f"{mean(x['success'] for x in bm[a, 'abl']) - mean(x['success'] for x in bm[t, 'abl']):+.1f}"
                      for _, t, a in RUNS))

    print("\nOne stage-1 iteration, stage1.bootstrap=actor (bench/train_throughput.py --config gpu --trunks small "
          "--no-parts; ms)\n")
    print("| renderer, worlds / updates | attempts/s | iteration | forward and choice | physics | render heightmaps "
          "| replay add | replay sample | updates | rest | update MFU |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for name, f in (("ray caster (jax), 512 / 16", "tp_actor_jax.json"), ("Warp, 512 / 16", "tp_actor_warp.json"),
                    ("Warp, 1,024 / 32", "tp_actor_warp_1024.json")):
        d = json.load(open(os.path.join(HERE, f)))
        p = d["phases"]
        ms = [1e3 * p[k] for k in ("forward_and_choice_s", "physics_s", "render_heightmaps_s", "replay_add_s",
                                   "replay_sample_s", "updates_s", "rest_of_iteration_s")]
        print(f"| {name} | {d['attempts_per_s']:.0f} | {1e3 * d['iteration_s']:.1f} | "
              + " | ".join(f"{v:.1f}" for v in ms) + f" | {100 * d['update_mfu'][0]['mfu']:.1f} % |")

    d = json.load(open(os.path.join(HERE, "tp_stage3_t31.json")))
    print(f"\nStage 3 of run t31 (the preset; bench/train_throughput.py --run RUN --stage stage3): "
          f"{d['attempts_per_s']:.0f} attempts/s, {1e3 * d['iteration_s']:.1f} ms an iteration\n")
    print("| phase | ms |")
    print("|---|---:|")
    for k, v in d["phases"].items():
        print(f"| {k.removesuffix('_s').replace('_', ' ')} | {1e3 * v:.1f} |")


if __name__ == "__main__":
    main()
