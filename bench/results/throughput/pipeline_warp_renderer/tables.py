"""Prints the tables of bench/RESULTS.md, "The whole gpu pipeline with the Warp renderer as the only
change": train.py --config gpu as it is (``t<S>/``) and with ``camera.renderer=warp
camera.render_batch=512`` (``w<S>/``) on one bare H200 (``driver_1gpu.sh``, then ``side_w34.sh``;
``machine_log.txt``).  Pair 34: t34 trained beside the first w34 and bench/render_parity.py (w34 ran
out of memory there and was trained again alone at the end, warm, without time for its
benchmark).  Pair 35: w35 then t35, each alone on the GPU.  Runs benchmarked as VAGS and its
ablation (groups 1-10 x 50 rounds, seeds 11-13).  Once ``driver_finish.sh`` has trained pair 34's
Warp side again with its benchmark (files in ``finish/``), that run takes w34's place in the rule,
and the tables end with the rule's verdict.
Run from anywhere: python bench/results/throughput/pipeline_warp_renderer/tables.py"""
import json
import os

HERE = os.path.dirname(os.path.abspath(__file__))
# driver_finish.sh trains pair 34's Warp side again with its benchmark; its files go to finish/.
W34 = "finish/w34b" if os.path.isdir(os.path.join(HERE, "finish", "w34b")) else "w34"
PAIRS = (("34", "t34", W34), ("35", "t35", "w35"))
EXTRA = (("34", "w34"),) if W34 != "w34" else ()  # rows shown, not in the rule
if os.path.isdir(os.path.join(HERE, "finish", "w35h")):  # by hand after h100_finish/driver.sh, outside the rule
    EXTRA += (("35", "finish/w35h"),)
HOW = {"t34": "H200, beside w34's first try (cold)", "w34": "H200, alone, after its first try (warm)",
       "t35": "H200, alone (warm)", "w35": "H200, alone (stage 2 and gate compiled in the run)",
       "finish/w34b": "H100, alone (cold, a fresh machine)", "finish/w35h": "H100, alone (warm, after finish/w34b)"}
# How the VAGS evaluations of each run shared the GPU (their wall clock depends on it).
EVAL_HOW = {"finish/w34b": "H100, two at once", "finish/w35h": "H100, alone"}
EVAL_SEEDS = (11, 12, 13)
QUARTERS = ((0, 30), (30, 60), (60, 90), (90, 120))


def load_jsonl(path):
    with open(path) as f:
        return [json.loads(line) for line in f if line.strip()]


def process_seconds(run):
    """train.py's process wall clock from its machine log (the last line for that run)."""
    log = os.path.join(HERE, os.path.dirname(run), "machine_log.txt")
    secs = [int(line.split()[2]) for line in open(log) if line.startswith(f"train_{os.path.basename(run)} rc=0 ")]
    return secs[-1]


def training(run):
    summary = json.load(open(os.path.join(HERE, run, "summary.json")))
    stages = {s["stage"]: s for s in summary["stages"]}
    timing = {t["stage"]: t for t in load_jsonl(os.path.join(HERE, run, "timings.jsonl"))}
    m = load_jsonl(os.path.join(HERE, run, "metrics.jsonl"))
    first_wall = m[0]["wall_s"]
    first_end = max(i for i, r in enumerate(m) if r["wall_s"] == first_wall)
    after = m[first_end + 1:]
    rate = sum(r["attempts"] for r in after) / (m[-1]["wall_s"] - first_wall)

    def success(lo, hi):
        part = [r for r in m if lo <= r["iteration"] < hi]
        return 100 * sum(r["success_rate"] * r["attempts"] for r in part) / sum(r["attempts"] for r in part)

    return {"process": process_seconds(run), "wall": summary["wall_s"],
            "stage": {k: stages[k]["wall_s"] for k in ("stage1", "stage2", "stage3", "gate")},
            "compile1": timing["stage1"]["compile"]["seconds"], "rate": rate,
            "quarters": [success(lo, hi) for lo, hi in QUARTERS],
            "recent": {k: 100 * stages[k]["recent_success_rate"] for k in ("stage1", "stage2", "stage3")},
            "gate": stages["gate"]}


def benchmark(run, policy):
    """Per evaluation seed: success, 6-10 success, clearing, motion number; None if not run."""
    out = []
    for s in EVAL_SEEDS:
        path = os.path.join(HERE, run, f"seed{s}", f"eval_{policy}.json")
        if not os.path.exists(path):
            return None
        d = json.load(open(path))
        big = [v for v in d["groups_metrics"] if v["n_objects"] >= 6]
        o = d["overall"]
        out.append({"success": 100 * o["grasp_success_rate"], "clearing": 100 * o["clearing_rate"],
                    "six": 100 * sum(v["successes"] for v in big) / sum(v["attempts"] for v in big),
                    "motion": o["motion_number"], "eval_wall": d["wall_s"]})
    return out


def mean(xs):
    xs = list(xs)
    return sum(xs) / len(xs)


def slash(evals):
    return " / ".join(f"{x['success']:.1f}" for x in evals)


def label(run):
    kind = "Warp renderer" if os.path.basename(run).startswith("w") else "preset (ray caster)"
    return f"{kind}, {run}"


def rows():
    """(training seed, run) in table order: each pair, then the extra rows."""
    return [(seed, r) for seed, t, w in PAIRS for r in (t, w)] + list(EXTRA)


def main():
    tr = {r: training(r) for _, r in rows()}
    print("The pipeline (train.py --config gpu; seconds)\n")
    print("| training seed | pipeline | how it ran | train.py process | pipeline wall (summary) | stage 1 | stage 2 "
          "| stage 3 | gate table | stage-1 compiling |")
    print("|---:|---|---|---:|---:|---:|---:|---:|---:|---:|")
    for seed, r in rows():
        x = tr[r]
        print(f"| {seed} | {label(r)} | {HOW[r]} | {x['process']} | {x['wall']:.1f} | {x['stage']['stage1']:.1f} "
              f"| {x['stage']['stage2']:.1f} | {x['stage']['stage3']:.1f} | {x['stage']['gate']:.1f} "
              f"| {x['compile1']:.1f} |")

    print("\nStage 1 and the training success\n")
    print("| training seed | pipeline | stage-1 attempts/s after its first chunk | stage-1 success % by quarter "
          "| stage 1 / 2 / 3 recent success % | gate: moving bins; GDNet direct / after a move |")
    print("|---:|---|---:|---|---|---|")
    for seed, r in rows():
        x = tr[r]
        q = " / ".join(f"{v:.1f}" for v in x["quarters"])
        rec = " / ".join(f"{x['recent'][k]:.1f}" for k in ("stage1", "stage2", "stage3"))
        g = x["gate"]
        print(f"| {seed} | {label(r)} | {x['rate']:.0f} | {q} | {rec} | {g['moving_bins']}; "
              f"{g['gdnet']} / {g['close_gdnet']} |")
    first = [tr[w]["quarters"][0] - tr[t]["quarters"][0] for _, t, w in PAIRS]
    print("\nStage 1's first-quarter success, Warp - preset, per pair (" + ", ".join(w for _, _, w in PAIRS) + "): "
          + ", ".join(f"{d:+.1f}" for d in first) + f"; mean {mean(first):+.2f} points")

    print("\nThe benchmark (eval.py, groups 1-10 x 50 rounds, seeds 11 / 12 / 13)\n")
    print("| training seed | pipeline | VAGS success % | mean | 6-10 mean | motion number mean | clearing % mean "
          "| ablation success % | mean | 6-10 mean | VAGS - ablation, 6-10 |")
    print("|---:|---|---|---:|---:|---:|---:|---|---:|---:|---:|")
    bm = {}
    for seed, r in rows():
        v = bm[r, "vags"] = benchmark(r, "vags")
        b = bm[r, "abl"] = benchmark(r, "vags-no-viewpoint")
        if v is None or b is None:
            print(f"| {seed} | {label(r)} | not run | | | | | not run | | | |")
            continue
        print(f"| {seed} | {label(r)} | {slash(v)} "
              f"| {mean(x['success'] for x in v):.1f} | {mean(x['six'] for x in v):.1f} "
              f"| {mean(x['motion'] for x in v):.3f} | {mean(x['clearing'] for x in v):.1f} "
              f"| {slash(b)} | {mean(x['success'] for x in b):.1f} "
              f"| {mean(x['six'] for x in b):.1f} | {mean(x['six'] for x in v) - mean(x['six'] for x in b):+.1f} |")
    diffs = {}
    for seed, t, w in PAIRS:
        if bm[w, "vags"] is None:
            continue
        diffs[seed] = [mean(x["success"] for x in bm[w, k]) - mean(x["success"] for x in bm[t, k]) for k in ("vags", "abl")]
        print(f"\nPair {seed}, Warp - preset: VAGS {diffs[seed][0]:+.2f} points, ablation {diffs[seed][1]:+.2f} points")
    print("\n500-round VAGS tables, eval.py's wall_s for seeds 12 and 13: "
          + "; ".join(f"{r} ({EVAL_HOW.get(r, 'H200, four at once')}) "
                      + ", ".join(f"{x['eval_wall']:.1f}" for x in bm[r, 'vags'][1:]) + " s"
                      for _, r in rows() if bm[r, "vags"] is not None))

    d = json.load(open(os.path.join(HERE, "render_parity.json")))
    print(f"\nrender_parity.py (64 scenes of 10 objects, 640 x 480): verdict {d['verdict']}; "
          f"depth within 1 mm {d['depth_within_1mm']:.4f}, same geom {d['same_geom']:.4f}, "
          f"heightmap mean |diff| {d['heightmap_mean_abs_mm']:.3f} mm, cells > 2 mm {d['heightmap_cells_over_2mm']:.4f}, "
          f"steep share ray caster {100 * d['steep_share_jax']:.3f} % / Warp estimate {100 * d['steep_share_warp']:.3f} % "
          f"(ratio {d['steep_share_ratio']:.3f})")

    # driver_1gpu.sh's rule: parity passes; over both pairs VAGS, the ablation and stage 1's first quarter
    # each no more than 2 points below the preset's; train.py's wall clock lower on pair 35.
    print("\nThe rule:")
    print(f"- render_parity.py: {d['verdict']}")
    print(f"- stage 1's first quarter, mean over both pairs: {mean(first):+.2f} points")
    if len(diffs) < len(PAIRS):
        print(f"- VAGS and the ablation: benchmarked on pair(s) {', '.join(diffs)} only; the rule needs both pairs")
        verdict = "cannot be applied"
    else:
        dv, da = mean(v for v, _ in diffs.values()), mean(a for _, a in diffs.values())
        print(f"- VAGS, mean over both pairs: {dv:+.2f} points; the ablation: {da:+.2f} points")
        faster = tr["w35"]["process"] < tr["t35"]["process"]
        met = d["verdict"] == "PASS" and min(mean(first), dv, da) >= -2.0 and faster
        verdict = "met" if met else "not met"
    print(f"- train.py on pair 35: {tr['w35']['process']} s (Warp) against {tr['t35']['process']} s")
    print(f"Verdict: {verdict}")


if __name__ == "__main__":
    main()
