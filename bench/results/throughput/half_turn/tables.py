"""Prints the tables of driver.sh and driver_views.sh in this directory: stage 1's rate side by
side over 16 whole-turn and 8 half-turn rotations (bench/train_throughput.py, tt_*.json); stage
1's success by quarter and the pipelines' wall clocks of h47 and hd47 against f47 and d47 (the
thirty-fourth look, the same seed over 16 rotations); the benchmark of all four, averaged over
seeds 11-13 (bench/viewpoint_goals.py's rows); the GDNets the rate gate's table compared in each
run; and the two-by-two of driver_views.sh: stage 1 trained over each rotation set, each
network evaluated over both.  Run from anywhere:
python bench/results/throughput/half_turn/tables.py"""
import gzip
import json
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", "..", "..", ".."))
sys.path.insert(0, os.path.join(ROOT, "bench"))
FULL_TURN = os.path.join(ROOT, "bench", "results", "viewpoints", "default", "thirtyfourth_look")
# run -> (its directory, stage1.bootstrap, rotations)
RUNS = {"f47": (os.path.join(FULL_TURN, "f47"), "target_network", "16 whole turn"),
        "h47": (os.path.join(HERE, "h47"), "target_network", "8 half turn"),
        "d47": (os.path.join(FULL_TURN, "d47"), "actor_argmax", "16 whole turn"),
        "hd47": (os.path.join(HERE, "hd47"), "actor_argmax", "8 half turn")}


def mean(xs):
    return sum(xs) / len(xs)


def throughput_table():
    print("| stage1.bootstrap | rotations | attempts/s (8 iterations) | ms per iteration | forward + choice ms | "
          "physics ms | render + heightmaps ms | 16 updates ms | one update ms | update MFU |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for name, boot in (("preset", "target_network"), ("argmax", "actor_argmax")):
        for turn, label in (("full", "16 whole turn"), ("half", "8 half turn")):
            with open(os.path.join(HERE, f"tt_{name}_{turn}.json")) as f:
                r = json.load(f)
            p, u = r["phases"], r["update_mfu"][0]
            print(f"| {boot} | {label} | {r['attempts_per_s']:,.0f} | {1000 * r['iteration_s']:.1f} | "
                  f"{1000 * p['forward_and_choice_s']:.1f} | {1000 * p['physics_s']:.1f} | "
                  f"{1000 * p['render_heightmaps_s']:.1f} | {1000 * p['updates_s']:.1f} | {1000 * u['update_s']:.1f} | "
                  f"{100 * u['mfu']:.1f} % |")


def stage1_rows(directory: str) -> list:
    path = os.path.join(directory, "metrics.jsonl.gz")
    with gzip.open(path, "rt") as f:
        return [r for r in map(json.loads, f) if r["stage"] == "stage1"]


def stage1_table():
    print("\n| run | stage1.bootstrap | rotations | stage 1: success % by quarter of its iterations | attempts | "
          "stage 1 s | of which loading + compiling s |")
    print("|---|---|---|---|---:|---:|---:|")
    for run, (d, boot, turn) in RUNS.items():
        rows = stage1_rows(d)
        q = len(rows) // 4
        quarters = [100 * sum(r["success_rate"] * r["attempts"] for r in rows[i * q:(i + 1) * q])
                    / sum(r["attempts"] for r in rows[i * q:(i + 1) * q]) for i in range(4)]
        with open(os.path.join(d, "timings.jsonl")) as f:
            t = next(r for r in map(json.loads, f) if r["stage"] == "stage1")
        print(f"| {run} | {boot} | {turn} | {' / '.join(f'{x:.1f}' for x in quarters)} | "
              f"{sum(r['attempts'] for r in rows):,.0f} | {t['wall_s']:.1f} | {t['compile']['seconds']:.1f} |")


def timing_table():
    from pipeline_times import table
    print()
    print(table(HERE, (("h47", "8 half-turn rotations, after the four rate runs"),
                       ("hd47", "h47 with stage1.bootstrap=actor_argmax"))))


def benchmark_table():
    from viewpoint_goals import read_report, row
    print("\n| run | rotations | VAGS % | ablation (GDNet alone) % | VAGS 6-10 - ablation 6-10 (per seed) | "
          "6-10 clearing: VAGS - ablation (per seed) | VAGS motion number | at 1 object: moves % |")
    print("|---|---|---:|---:|---|---|---:|---|")
    for run, (d, _, turn) in RUNS.items():
        v = [row(read_report(os.path.join(d, f"seed{s}", "eval_vags.json"))) for s in (11, 12, 13)]
        a = [row(read_report(os.path.join(d, f"seed{s}", "eval_vags-no-viewpoint.json"))) for s in (11, 12, 13)]
        margin = " / ".join(f"{100 * (x['success_6_10'] - y['success_6_10']):+.1f}" for x, y in zip(v, a))
        clear = " / ".join(f"{100 * (x['clearing_6_10'] - y['clearing_6_10']):+.1f}" for x, y in zip(v, a))
        ones = " / ".join(f"{100 * x['viewpoint_1']:.1f}" for x in v)
        print(f"| {run} | {turn} | {100 * mean([x['success'] for x in v]):.1f} | "
              f"{100 * mean([x['success'] for x in a]):.1f} | {margin} | {clear} | "
              f"{mean([x['motion_number'] for x in v]):.2f} | {ones} |")


def pick_table():
    """The GDNets the gate table measured (gate.json "gdnet_pick"): success of the direct grasp
    and of the grasp after a move on the table's states, and the one kept ("gdnet")."""
    from viewpoint_goals import read_report  # a JSON file, or gzipped beside it
    print("\n| run | candidate | direct grasp success % | grasp after a move success % | picks per second | kept |")
    print("|---|---|---:|---:|---:|---|")
    for run, (d, _, _) in RUNS.items():
        g = read_report(os.path.join(d, "gate.json"))
        for name, c in g["gdnet_pick"].items():
            kept = (c["gdnet"], c["close_gdnet"]) == (g["gdnet"], g["close_gdnet"])
            print(f"| {run} | {name} | {100 * c['direct_success']:.1f} | {100 * c['moved_success']:.1f} | "
                  f"{c['rate']:.4f} | {'yes' if kept else ''} |")


def views_table():
    from viewpoint_goals import read_report, row
    print("\n| stage 1 trained over | acting over | success % (seeds 11 / 12 / 13) | mean % | 6-10 success % mean | "
          "motion number |")
    print("|---|---|---|---:|---:|---:|")
    for trained, tlabel in (("s47full", "16 whole turn"), ("s47half", "8 half turn")):
        for act, alabel in (("act_full", "16 whole turn"), ("act_half", "8 half turn")):
            rows = [row(read_report(os.path.join(HERE, "views", trained, act, f"seed{s}", "eval_gdnet.json")))
                    for s in (11, 12, 13)]
            each = " / ".join(f"{100 * r['success']:.1f}" for r in rows)
            print(f"| {tlabel} | {alabel} | {each} | "
                  f"{100 * mean([r['success'] for r in rows]):.1f} | {100 * mean([r['success_6_10'] for r in rows]):.1f} | "
                  f"{mean([r['motion_number'] for r in rows]):.2f} |")


def main():
    throughput_table()
    stage1_table()
    timing_table()
    benchmark_table()
    pick_table()
    views_table()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
