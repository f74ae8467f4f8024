"""The verdict of bench/render_parity.py (Warp renderer vs the JAX ray caster).

The comparison itself needs an NVIDIA GPU (its output is in bench/RESULTS.md); here, on CPU,
the statistics and thresholds are checked on hand-made renders, and the script's refusal to
run without warp-lang or a GPU.  Nothing is compiled.
"""
import importlib.util
import os
import sys

import numpy as np
import pytest

_PATH = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "bench", "render_parity.py")
_spec = importlib.util.spec_from_file_location("render_parity", _PATH)
rp = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(rp)


def _scene(b=2, h=40, w=50, hm=20):
    """Two renders that agree exactly: depth 0.6 m with a 10-pixel-wide band of misses,
    geom ids by column, heightmaps of 0-5 cm."""
    depth = np.full((b, h, w), 0.6)
    depth[:, :, :10] = 0.0
    geom = np.broadcast_to(np.arange(w) // 10, (b, h, w)).copy()
    height = np.linspace(0.0, 0.05, b * hm * hm).reshape(b, hm, hm)
    return depth, geom, height


def test_identical_renders_pass():
    d, g, hm = _scene()
    stats = rp.parity_stats(d, g, hm, d, g, hm)
    assert stats["hit_by_both"] == pytest.approx(0.8)  # 40 of 50 columns hit
    assert stats["depth_within_1mm"] == 1.0 and stats["same_geom"] == 1.0
    assert stats["hit_miss_disagreement"] == 0.0 and stats["heightmap_mean_abs_mm"] == 0.0
    assert rp.failures(stats) == []


def test_the_measured_h100_figures_pass():
    # bench/RESULTS.md, eighth pass: 0.9998 / 0 / 0.9999 / 0.158 mm / 0.0018.
    stats = {"hit_by_both": 1.0, "depth_within_1mm": 0.9998, "max_depth_diff_mm": 154.79,
             "hit_miss_disagreement": 0.0, "same_geom": 0.9999, "heightmap_mean_abs_mm": 0.158,
             "heightmap_cells_over_2mm": 0.0018}
    assert rp.failures(stats) == []


def test_each_kind_of_mismatch_fails_and_is_named():
    d, g, hm = _scene()
    # 1.5 mm off on 1 % of the pixels hit by both (32 of 3,200): 0.99 < 0.999.
    d2 = d.copy()
    d2[0, :32, 20] += 0.0015
    f = rp.failures(rp.parity_stats(d, g, hm, d2, g, hm))
    assert len(f) == 1 and "|depth diff| <= 1 mm 0.99" in f[0]
    # One renderer misses a column the other hits: 40 / 4,000 = 0.01 > 0.001.
    d3 = d.copy()
    d3[0, :, 30] = 0.0
    f = rp.failures(rp.parity_stats(d, g, hm, d3, g, hm))
    assert any("hit by one renderer only" in x for x in f)
    # Another geom on 2 of 3,200 pixels hit by both is within the 0.1 % allowed; 8 are not.
    g2 = g.copy()
    g2[0, :2, 25] = 99
    assert rp.failures(rp.parity_stats(d, g, hm, d, g2, hm)) == []
    g2[0, :8, 25] = 99
    f = rp.failures(rp.parity_stats(d, g, hm, d, g2, hm))
    assert len(f) == 1 and "same geom" in f[0]
    # Heightmaps 1 mm off everywhere: mean 1 mm > 0.5 mm, but no cell > 2 mm.
    f = rp.failures(rp.parity_stats(d, g, hm, d, g, hm + 0.001))
    assert len(f) == 1 and "mean |diff|" in f[0]
    # 3 mm off on 8 of the 800 cells (share 0.01, at the limit; mean 0.03 mm) passes; on 16
    # (share 0.02) the share of cells > 2 mm fails while the mean (0.06 mm) still passes.
    hm2 = hm.copy()
    hm2[0, :4, :2] += 0.003
    assert rp.failures(rp.parity_stats(d, g, hm, d, g, hm2)) == []
    hm2[1, :4, :2] += 0.003
    f = rp.failures(rp.parity_stats(d, g, hm, d, g, hm2))
    assert len(f) == 1 and "> 2 mm" in f[0]


def test_renders_with_no_common_hit_fail():
    d, g, hm = _scene()
    empty = np.zeros_like(d)
    f = rp.failures(rp.parity_stats(d, g, hm, empty, g, hm))
    assert "no pixel was hit by both renderers" in f


def test_without_warp_it_stops_with_one_clear_line(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "warp", None)
    assert rp.main(["--worlds", "2", "--objects", "2"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "needs warp-lang" in err[0] and ".[warp]" in err[0]


@pytest.mark.parametrize("argv,msg", [
    (["--objects", "11"], "--objects must be in 1..10"),
    (["--set", "nosuch.field=1"], "nosuch"),
])
def test_bad_arguments_stop_before_any_rendering(argv, msg, capsys):
    assert rp.main(argv) == 2
    assert msg in capsys.readouterr().err


def test_bad_world_count_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as e:
        rp.parse_args(["--worlds", "0"])
    assert e.value.code == 2 and "--worlds must be in 1..1024" in capsys.readouterr().err


def test_the_steep_face_share_of_the_warp_estimate_is_checked():
    d, _, _ = _scene()
    exact = np.full(d.shape, 0.9)
    exact[:, :2, 10:] = 0.1  # 2 of 40 rows of the hit pixels are steep faces: 5 %
    same = rp.steep_stats(exact, d, exact, d, 75.0)
    assert same["steep_share_jax"] == pytest.approx(0.05) and same["steep_share_ratio"] == pytest.approx(1.0)
    assert rp.failures(same, rp.SENSOR_THRESHOLDS) == []
    # Silhouettes seen as grazing faces: twice the steep pixels fails, and so does half of them.
    est = exact.copy()
    est[:, 2:4, 10:] = 0.1
    f = rp.failures(rp.steep_stats(exact, d, est, d, 75.0), rp.SENSOR_THRESHOLDS)
    assert len(f) == 1 and "steep-face pixels" in f[0] and "0.8 .. 1.25" in f[0]
    est = exact.copy()
    est[:, 1, 10:] = 0.9
    assert len(rp.failures(rp.steep_stats(exact, d, est, d, 75.0), rp.SENSOR_THRESHOLDS)) == 1
    # Pixels nothing hit do not count (their incidence is 0).
    assert rp.steep_stats(np.where(d > 0, exact, 0.0), d, exact, d, 75.0)["steep_share_ratio"] == pytest.approx(1.0)


def test_the_hit_miss_breakdown_counts_what_the_check_counts():
    """Pixels hit by one renderer only, by the hit geom's type, and apart from them those beyond
    0.9 x far that the check leaves out (the H200 run of 2026-11-29 listed 34,688 plane pixels
    under a disagreement of 0: they were all at the far clip)."""
    dj, gj, _ = _scene()
    dw, gw = dj.copy(), gj.copy()
    dw[0, 0, 20:23] = 0.0  # geom 2 (type 6, box): seen by the ray caster only
    dj[1, 5, 40] = 0.0  # geom 4 (type 0, plane): seen by Warp only
    dw[1, 6, 30], gw[1, 6, 30] = 0.0, 3  # the ray caster's hit beyond 0.9 x far
    dj[1, 6, 30] = 0.95
    geom_type = np.array([0, 0, 6, 6, 0])
    out = rp.hit_miss_breakdown(dj, gj, dw, gw, geom_type, {0: "plane", 6: "box"}, far=1.0)
    assert out == {"hit_miss_by_geom_type": {"plane": 1, "box": 3}, "hit_miss_at_far_clip": 1}
    stats = rp.parity_stats(dj, gj, np.zeros((2, 4, 4)), dw, gw, np.zeros((2, 4, 4)), 1.0)
    assert stats["hit_miss_disagreement"] * dj.size == 4
