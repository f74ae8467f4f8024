"""Prints the tables of driver.sh in this directory: both pipelines' wall clocks and stages
(bench/pipeline_times.py); f47's same-states table with the planned branch (bench/gate_headroom.py's
headroom.json); stage 1 of f47 and d47 (stage1.bootstrap=actor_argmax) by quarters, and the
side-by-side stage-1 rate (bench/results/throughput/actor_argmax_h100); both runs' benchmark
against issue 23's goals (bench/viewpoint_goals.py); f47's VAGS against the ablation with the
success net's direct grasp; the standard errors of the gate tables' move values for today's preset's
trainings (f41, f44, f47, d47), fit again from their saved states.  Run from anywhere:
python bench/results/viewpoints/default/thirtyfourth_look/tables.py"""
import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", "..", "..", "..", ".."))
sys.path.insert(0, os.path.join(ROOT, "bench"))
RUNS = (("f47", "cold (empty cache)"), ("d47", "stage1.bootstrap=actor_argmax, from f47's cache"))


def timing_table():
    from pipeline_times import table
    print(table(HERE, RUNS))


def headroom_table():
    from gate_headroom import table
    with open(os.path.join(HERE, "f47", "headroom.json")) as f:
        got = json.load(f)
    print(f"\nf47's gate table states ({got['measure']['live_states']} live; GDNets {got['gdnet_pick']}; moving bins "
          f"{got['moving_bins']['moving_bins']} of {got['moving_bins']['bins']}; {got['measure']['wall_s']} s on "
          f"{got['device']})\n")
    print(table(got["summary"]))


def stage1_rows(run: str) -> list:
    import gzip
    with gzip.open(os.path.join(HERE, run, "metrics.jsonl.gz"), "rt") as f:
        return [r for r in map(json.loads, f) if r["stage"] == "stage1"]


def stage1_table():
    """Stage 1's success over each quarter of its iterations (attempt-weighted), its attempts,
    and its wall clock less its loading and compiling (timings.jsonl)."""
    print("\n| run | stage 1: success % by quarter of its iterations | attempts | stage 1 s | of which loading "
          "+ compiling s | stage 1 s less compiling |")
    print("|---|---|---:|---:|---:|---:|")
    for run, _ in RUNS:
        rows = stage1_rows(run)
        q = len(rows) // 4
        quarters = []
        for i in range(4):
            part = rows[i * q:(i + 1) * q]
            quarters.append(100 * sum(r["success_rate"] * r["attempts"] for r in part) / sum(r["attempts"] for r in part))
        with open(os.path.join(HERE, run, "timings.jsonl")) as f:
            t = next(r for r in map(json.loads, f) if r["stage"] == "stage1")
        print(f"| {run} | {' / '.join(f'{x:.1f}' for x in quarters)} | {sum(r['attempts'] for r in rows):,.0f} | "
              f"{t['wall_s']:.1f} | {t['compile']['seconds']:.1f} | {t['wall_s'] - t['compile']['seconds']:.1f} |")


def throughput_table():
    d = os.path.join(ROOT, "bench", "results", "throughput", "actor_argmax_h100")
    print("\n| stage1.bootstrap | attempts/s (8 iterations) | ms per iteration | one update ms | update model GFLOP "
          "| update MFU |")
    print("|---|---:|---:|---:|---:|---:|")
    for b in ("target_network", "actor_argmax"):
        with open(os.path.join(d, f"tt_{b}.json")) as f:
            r = json.load(f)
        u = r["update_mfu"][0]
        print(f"| {b} | {r['attempts_per_s']:.0f} | {1000 * r['iteration_s']:.1f} | {1000 * u['update_s']:.1f} | "
              f"{u['update_flops'] / 1e9:,.1f} | {100 * u['mfu']:.1f} % |")


def success_direct_table():
    """f47's VAGS against the ablation with the success net's direct grasp, on the same scenes."""
    from viewpoint_goals import read_report, row
    print("\n| seed | VAGS % | ablation, success net's direct grasp % | VAGS 6-10 % | that ablation 6-10 % | "
          "6-10: VAGS - that ablation | that ablation's motion number | same scenes |")
    print("|---:|---:|---:|---:|---:|---:|---:|---|")
    for seed in (11, 12, 13):
        v = read_report(os.path.join(HERE, "f47", f"seed{seed}", "eval_vags.json"))
        s = read_report(os.path.join(HERE, "f47", "success", f"seed{seed}", "eval_vags-no-viewpoint.json"))
        rv, rs = row(v), row(s)
        print(f"| {seed} | {100 * rv['success']:.1f} | {100 * rs['success']:.1f} | {100 * rv['success_6_10']:.1f} | "
              f"{100 * rs['success_6_10']:.1f} | {100 * (rv['success_6_10'] - rs['success_6_10']):+.1f} | "
              f"{rs['motion_number']:.3f} | {v['scenes'] == s['scenes']} |")


def bin_noise_table():
    """Each table fit again from its saved states over its own bins (``rate_gate.fit``, which now
    records each bin's standard error): bins 0-2's move values, and the bins within two
    standard errors of 0 (``rate_gate.close_bins``)."""
    sys.path.insert(0, ROOT)
    from vags_jax.policies import rate_gate
    print("\n| run | moving bins | bin 0 move value | bin 1 | bin 2 | bins within two standard errors of 0 |")
    print("|---|---|---:|---:|---:|---|")
    for run, rel in (("f41", ("..", "thirtysecond_look", "f41")), ("f44", ("..", "thirtythird_look", "f44")),
                     ("f47", ("f47",)), ("d47", ("d47",))):
        d = os.path.join(HERE, *rel)
        saved, st = rate_gate.from_dict(rate_gate.read(d)), rate_gate.read_states(d)
        t = rate_gate.fit(st["p_direct"], st["direct_success"], st["direct_seconds"], st["moved_success"],
                          st["moved_seconds"], len(saved.states), lost_direct=st.get("direct_lost"),
                          lost_moved=st.get("moved_lost"), count_lost=saved.count_lost)
        assert t.move_value == saved.move_value, run  # the same fit as the run's own
        v = [f"{t.move_value[k]:+.3f} ± {t.move_value_se[k]:.3f}" for k in range(3)]
        print(f"| {run} | {rate_gate.moves_summary(t)['moving_bins']} | {v[0]} | {v[1]} | {v[2]} | "
              f"{rate_gate.close_bins(t)} |")


def main():
    timing_table()
    headroom_table()
    stage1_table()
    throughput_table()
    for run in ("f47", "d47"):
        print(f"\n{run}:")
        sys.stdout.flush()
        subprocess.run([sys.executable, os.path.join(ROOT, "bench", "viewpoint_goals.py"), os.path.join(HERE, run)],
                       check=False)
    success_direct_table()
    bin_noise_table()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
