"""bench/incidence_estimate.py: its figures on hand-made arrays, its table, and its input checks
(the measurement itself renders settled scenes; it is run by hand, bench/RESULTS.md)."""
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "bench"))
import incidence_estimate as ie  # noqa: E402


def test_summarise_counts_against_the_exact_incidence():
    exact = np.array([[0.9, 0.9, 0.1, 0.0]])
    est = np.array([[0.9, 0.2, 0.1, 0.0]])  # one more steep pixel, one steep decision flipped
    hit = np.array([[1, 1, 1, 0]])
    depth_exact = np.array([[0.5, 0.5, 0.0, 0.0]])  # the steep pixel dropped
    depth_est = np.array([[0.5, 0.0, 0.0, 0.0]])
    height_exact = np.zeros((1, 2, 2))
    height = height_exact + np.array([[[0.0, 0.003], [0.001, 0.0]]])  # one cell 3 mm off
    source = np.array([[[0, 1], [-1, 2]]])  # one hole of four cells
    colour_exact = np.full((1, 4, 3), 100, np.uint8)
    colour = colour_exact.copy()
    colour[0, 0] = 112
    f = ie.summarise(exact, est, hit, 0.26, depth_est, depth_exact, height, source, height_exact, colour, colour_exact)
    assert f["steep_share"] == pytest.approx(2 / 3)
    assert f["steep_decisions_differing"] == pytest.approx(1 / 3)
    assert f["mean_abs_cos_error"] == pytest.approx(0.7 / 3)
    assert f["image_holes"] == pytest.approx(2 / 3) and f["image_pixels_differing"] == pytest.approx(1 / 3)
    assert f["heightmap_holes"] == 0.25 and f["heightmap_cells_over_2mm"] == 0.25
    assert f["heightmap_mean_abs_colour"] == pytest.approx(12 * 3 / 12)
    same = ie.summarise(exact, exact, hit, 0.26, depth_exact, depth_exact, height_exact, source, height_exact,
                        colour_exact, colour_exact)
    assert same["steep_decisions_differing"] == 0 and same["heightmap_cells_over_2mm"] == 0
    rows = ie.table({"figures": {name: f for name in ie.ESTIMATES}}).splitlines()
    assert len(rows) == 2 + len(ie.ESTIMATES) and rows[2].startswith("| exact | 66.67 | 33.33 |")


def test_bad_inputs_end_in_one_line(capsys):
    assert ie.main(["--config", "tiny", "--objects", "9"]) == 2
    assert "--objects must be in 1..3" in capsys.readouterr().err
    assert ie.main(["--config", "tiny", "--set", "camera.noise.enabled=false"]) == 2
    assert "the sensor model" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        ie.parse_args(["--worlds", "0"])
