"""Prints driver.sh's table: per process (A the defaults, B XLA's CUDA graphs down to one kernel,
C B plus WHILE and CONDITIONAL in XLA's command buffers), the grasp loop's time for 512 worlds
and the 0.2 s settle's steps/s through our loop, a bare scan, unrolled, and unrolled with
graphs of one kernel.  python bench/results/throughput/physics_graphs/tables.py"""
import json
import os

HERE = os.path.dirname(os.path.abspath(__file__))
NAMES = {"A": "defaults", "B": "--xla_gpu_graph_min_graph_size=1",
         "C": "B + WHILE, CONDITIONAL in --xla_gpu_enable_command_buffer"}


def main():
    print("| process | XLA flags | grasp loop ms (512 grasps, 148 steps) | grasps/s | settle steps/s | bare scan | "
          "bare, unrolled 4 | bare, unrolled 4, graphs of >= 1 kernel |")
    print("|---|---|---:|---:|---:|---:|---:|---:|")
    for v in "ABC":
        with open(os.path.join(HERE, f"{v}.jsonl")) as f:
            for i, r in enumerate(map(json.loads, f), 1):
                print(f"| {v}{i} | {NAMES[v]} | {1000 * r['grasp_s']:.1f} | {r['grasps_per_s']:,.0f} | "
                      f"{r['settle_steps_per_s']:,.0f} | {r['raw_steps_per_s']:,.0f} | "
                      f"{r['raw_unroll4_steps_per_s']:,.0f} | {r['raw_unroll4_graph1_steps_per_s']:,.0f} |")


if __name__ == "__main__":
    main()
