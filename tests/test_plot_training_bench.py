"""bench/plot_training.py's reading of a run's metrics, plain or gzipped as committed, stage 1's
rows only, in iteration order; and its windowed success, worked out by hand."""
import gzip
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "bench"))
from plot_training import load, windowed  # noqa: E402

ROWS = [  # out of order, with a stage-2 row that must be left out
    {"stage": "stage1", "iteration": 1, "grasp_attempts": 20, "success_rate": 0.5, "wall_s": 3.0},
    {"stage": "stage1", "iteration": 0, "grasp_attempts": 10, "success_rate": 0.2, "wall_s": 2.0},
    {"stage": "stage2", "iteration": 0, "grasp_attempts": 99, "success_rate": 0.9, "wall_s": 9.0},
    {"stage": "stage1", "iteration": 2, "grasp_attempts": 30, "success_rate": 1.0, "wall_s": 4.0},
]


def test_load_reads_plain_and_gzipped_metrics(tmp_path):
    text = "\n".join(json.dumps(r) for r in ROWS) + "\n"
    plain, packed = tmp_path / "plain", tmp_path / "packed"
    plain.mkdir()
    packed.mkdir()
    (plain / "metrics.jsonl").write_text(text)
    with gzip.open(packed / "metrics.jsonl.gz", "wt") as f:
        f.write(text)
    for run in (plain, packed):
        att, succ, wall = load(str(run))
        np.testing.assert_array_equal(att, [10, 20, 30])
        np.testing.assert_array_equal(succ, [0.2, 0.5, 1.0])
        np.testing.assert_array_equal(wall, [2.0, 3.0, 4.0])


def test_windowed_success_weights_iterations_by_their_attempts():
    # 10 attempts an iteration at 0.2, 0.5, 1.0: a window of 20 attempts holds the last two.
    w = windowed(np.array([10.0, 20.0, 30.0]), np.array([0.2, 0.5, 1.0]), 20)
    np.testing.assert_allclose(w, [0.2, (2 + 5) / 20, (5 + 10) / 20])
