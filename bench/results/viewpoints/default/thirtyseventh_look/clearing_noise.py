"""How far the 6-10 clearing goal is from noise: VAGS against its own ablation, paired round by
round on the same scenes (bench/viewpoint_goals.py's paired_rounds), on every training of the
thirty-second to thirty-seventh looks evaluated that way (q runs and the q_mean runs trained as
such; not the q_mean copies of the thirty-fifth and thirty-sixth looks, whose ablations played
another GDNet), then the mean over all their seeds; and why piles of 6-10 objects are not
cleared on q52 and q53: an object lost (its centre left the workspace without a grasp) or objects
left on the table when the attempts ran out.  Run from anywhere:
python bench/results/viewpoints/default/thirtyseventh_look/clearing_noise.py"""
import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
LOOKS = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(LOOKS, "..", "..", ".."))  # bench/
from viewpoint_goals import paired_rounds, read_report  # noqa: E402

RUNS = ("thirtysecond_look/f41", "thirtythird_look/f44", "thirtyfourth_look/f47", "thirtyfourth_look/d47",
        "thirtyfifth_look/r48", "thirtyfifth_look/r49", "thirtysixth_look/r50", "thirtysixth_look/r51",
        "thirtyseventh_look/q52", "thirtyseventh_look/q53")


def main():
    print("| run | seed | rounds | 6-10 success: VAGS - ablation | 6-10 clearing: VAGS - ablation |")
    print("|---|---:|---:|---:|---:|")
    succ, clear, met = [], [], 0
    for run in RUNS:
        ok = True
        for seed in (11, 12, 13):
            d = os.path.join(LOOKS, run, f"seed{seed}")
            v = paired_rounds(read_report(os.path.join(d, "eval_vags.json")),
                              read_report(os.path.join(d, "eval_vags-no-viewpoint.json")), 6, 10)
            succ.append(v[0]), clear.append(v[2])
            ok &= v[2] >= -1e-9
            print(f"| {run.split('/')[1]} | {seed} | {v[4]} | {100 * v[0]:+.1f} ± {100 * v[1]:.1f} | "
                  f"{100 * v[2]:+.1f} ± {100 * v[3]:.1f} |")
        met += ok
    n = len(clear)
    mean = lambda x: sum(x) / len(x)  # noqa: E731
    sd = lambda x: math.sqrt(sum((a - mean(x)) ** 2 for a in x) / (len(x) - 1))  # noqa: E731
    print(f"\nover {n} (training, seed) pairs: 6-10 success {100 * mean(succ):+.1f} ± {100 * sd(succ) / math.sqrt(n):.1f}, "
          f"6-10 clearing {100 * mean(clear):+.1f} ± {100 * sd(clear) / math.sqrt(n):.1f} points "
          f"(mean ± standard error across the pairs); clearing no worse on all three seeds: {met} of {len(RUNS)} trainings")


def why_not_cleared():
    print("\n| run | policy | rounds of 6-10 objects | cleared % | an object lost % | objects left, none lost % |")
    print("|---|---|---:|---:|---:|---:|")
    for run in RUNS[-2:]:
        for pol in ("vags", "vags-no-viewpoint"):
            rounds = cleared = lost = left = 0
            for seed in (11, 12, 13):
                rep = read_report(os.path.join(LOOKS, run, f"seed{seed}", f"eval_{pol}.json"))
                for n in range(6, 11):
                    o = rep["outcomes"][str(n)]
                    for objects, successes, remaining in zip(o["n_objects"], o["successes"], o["remaining"]):
                        gone = objects - successes - remaining
                        rounds += 1
                        cleared += successes >= objects
                        lost += gone > 0
                        left += remaining > 0 and gone == 0
            print(f"| {run.split('/')[1]} | {pol} | {rounds} | {100 * cleared / rounds:.1f} | {100 * lost / rounds:.1f} | "
                  f"{100 * left / rounds:.1f} |")


if __name__ == "__main__":
    main()
    why_not_cleared()
