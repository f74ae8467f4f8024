"""Stage 1 alone (driver_stage1.sh): milliseconds per iteration and attempts/s after the first
chunk, and success by quarter, for s_e38 (the preset, cold cache), s_n38 (net.forward_needed_only)
and s_e38w (the preset on a warm cache).  Run from anywhere:
python bench/results/throughput/forward_needed/tables_stage1.py"""
import os

from tables import HERE, after_first_chunk, load_jsonl, quarters

RUNS = (("s_e38", "preset, cold cache"), ("s_n38", "forward_needed_only"), ("s_e38w", "preset, warm cache"))


def main():
    print("| run | ms per iteration after the first chunk | attempts/s after the first chunk | success % by quarter |")
    print("|---|---:|---:|---|")
    for run, name in RUNS:
        path = os.path.join(HERE, run, "metrics.jsonl")
        if not os.path.exists(path):
            print(f"| {name} | not run | | |")
            continue
        rows = load_jsonl(path)
        ms, rate = after_first_chunk(rows)
        print(f"| {name} | {ms:.1f} | {rate:.0f} | {' / '.join(f'{q:.1f}' for q in quarters(rows))} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
