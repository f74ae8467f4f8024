"""The tiny pipeline (2 worlds, stages of 4 / 2 / 4 iterations, no gate table, the compile cache
off) in one process: every stage's metrics rows and timings.jsonl -> JSON (argv[1]).  Run from a
checkout before and after a change to compare the two files (bench/RESULTS.md, "Stages 2 and 3
share one program"):

    PYTHONPATH=. python bench/results/stage23_program/tiny_pipeline.py /tmp/after.json
    python bench/results/stage23_program/tiny_pipeline.py --compare before.json after.json
"""
import json
import os
import shutil
import sys
import tempfile


def run(out_json):
    import train
    from vags_jax.stages import driver

    over = {"stage1.n_worlds": 2, "stage1.max_objects": 2, "stage1.learning_starts": 2, "dqn.batch_size": 4,
            "replay.capacity": 64, "stage1.iterations": 4, "stage2.iterations": 2, "stage3.iterations": 4,
            "gate_table.worlds": 0}
    for n in (2, 3):
        over.update({f"stage{n}.n_worlds": 2, f"stage{n}.max_objects": 2, f"stage{n}.learning_starts": 2})
    out = tempfile.mkdtemp(prefix="tiny_pipeline_")
    rc = train.main(["--config", "tiny", "--chunk", "2", "--quiet", "--cache-dir", "off", "--out", out, "--set"]
                    + [f"{k}={v}" for k, v in over.items()], driver.Programs())
    rows = []
    for stage in ("stage1", "stage2", "stage3"):
        with open(os.path.join(out, *(() if stage == "stage1" else (stage,)), "metrics.jsonl")) as f:
            for line in f:
                r = json.loads(line)
                r.pop("wall_s", None)
                rows.append(r)
    with open(os.path.join(out, "timings.jsonl")) as f:
        timings = [json.loads(line) for line in f]
    shutil.rmtree(out, ignore_errors=True)
    with open(out_json, "w") as f:
        json.dump({"rc": rc, "rows": rows, "timings": timings}, f)


def compare(a_path, b_path):
    a, b = (json.load(open(p)) for p in (a_path, b_path))
    for ta, tb in zip(a["timings"], b["timings"]):
        print(f"{ta['stage']}: {ta['wall_s']} s, compiled {ta['compile']['compiled']} | "
              f"{tb['wall_s']} s, compiled {tb['compile']['compiled']}")
    differ = [(ra["stage"], ra["iteration"], k) for ra, rb in zip(a["rows"], b["rows"]) for k in ra
              if ra[k] != rb.get(k)]
    print(f"{len(a['rows'])} and {len(b['rows'])} metrics rows; values that differ: {len(differ)} {differ[:5]}")


if __name__ == "__main__":
    if sys.argv[1] == "--compare":
        compare(sys.argv[2], sys.argv[3])
    else:
        run(sys.argv[1])
