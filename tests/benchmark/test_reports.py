"""Report files (CSV, plots) and attempt pictures: numpy only, no JAX compile."""
from __future__ import annotations

import csv
import json
import os
import sys
import zlib

import numpy as np
import pytest

from vags_jax.benchmark import record, reports as report_files
from vags_jax.benchmark.record import FAILURE_RGB, SUCCESS_RGB, AttemptRecord, attempt_picture, write_round
from vags_jax.benchmark.reports import SUMMARY_KEYS, SWEEP_COLUMNS, MissingPlotExtra


def _metrics(attempts, successes, cleared, rounds=2, viewpoints=0):
    return {
        "rounds": rounds, "objects": 3 * rounds, "attempts": attempts, "successes": successes,
        "motions": attempts + viewpoints,
        "grasp_success_rate": successes / attempts if attempts else None,
        "clearing_rate": cleared / rounds,
        "motion_number": (attempts + viewpoints) / successes if successes else None,
        "picks_per_hour": 700.0 * successes / max(attempts, 1) if successes else None,
        "robot_seconds": 5.0 * attempts, "attempts_per_round": attempts / rounds,
        "on_object_rate": 0.75, "viewpoint_rate": viewpoints / attempts if attempts else None,
        "objects_lost": 1, "physics_errors": 0, "buffer_overflows": 0,
    }


def _report(policy="gdnet"):
    g1 = {"n_objects": 1, **_metrics(4, 3, 1), "wall_s": 1.5}
    g3 = {"n_objects": 3, **_metrics(8, 0, 0), "wall_s": 2.5}  # no successes: None ratios
    overall = _metrics(12, 3, 1, rounds=4)
    return {"policy": policy, "seed": 0, "rounds": 2, "groups": [1, 3], "max_attempts": 11,
            "time_model": {}, "groups_metrics": [g1, g3], "overall": overall, "outcomes": {}}


def _read(path):
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        return reader.fieldnames, list(reader)


# ----------------------------------------------------------------------------- CSV


def test_csv_rows_columns_values_and_empty_cells(tmp_path):
    path = tmp_path / "r.csv"
    report_files.write_csv(_report(), str(path))
    header, rows = _read(path)
    assert header == ["policy", "n_objects", *SUMMARY_KEYS]
    assert [r["n_objects"] for r in rows] == ["1", "3", "overall"]
    assert all(r["policy"] == "gdnet" for r in rows)
    assert float(rows[0]["grasp_success_rate"]) == pytest.approx(0.75)
    assert int(rows[0]["successes"]) == 3 and int(rows[1]["attempts"]) == 8
    # group 3 has no successes: its motion number and picks per hour are None -> empty
    assert rows[1]["motion_number"] == "" and rows[1]["picks_per_hour"] == ""
    assert float(rows[1]["grasp_success_rate"]) == 0.0  # 0 is written, not emptied
    assert int(rows[2]["attempts"]) == 12 and float(rows[2]["clearing_rate"]) == pytest.approx(0.25)
    assert float(rows[2]["robot_seconds"]) == pytest.approx(60.0)


def test_csv_extra_columns_after_policy(tmp_path):
    path = tmp_path / "r.csv"
    report_files.write_csv(_report("vags"), str(path), extra={"threshold": 1.78, "objects_set": "unseen"})
    header, rows = _read(path)
    assert header[:4] == ["policy", "threshold", "objects_set", "n_objects"]
    assert header[4:] == list(SUMMARY_KEYS)
    assert len(rows) == 3
    assert all(float(r["threshold"]) == 1.78 and r["objects_set"] == "unseen" for r in rows)


def test_csv_refuses_bad_reports(tmp_path):
    bad = _report()
    del bad["groups_metrics"][1]["clearing_rate"]
    with pytest.raises(ValueError, match=r"groups_metrics'\]\[1\].*clearing_rate"):
        report_files.write_csv(bad, str(tmp_path / "x.csv"))
    with pytest.raises(ValueError, match="clash"):
        report_files.write_csv(_report(), str(tmp_path / "x.csv"), extra={"attempts": 3})
    with pytest.raises(ValueError, match="overall"):
        report_files.write_csv({"policy": "p", "groups_metrics": []}, str(tmp_path / "x.csv"))


def _sweep():
    return [
        {"kind": "absolute", "quantile": None, "threshold": 1.8, "overall": _metrics(10, 8, 1, viewpoints=2),
         "groups_metrics": []},
        {"kind": "absolute", "quantile": None, "threshold": 1.7, "overall": _metrics(10, 6, 0, viewpoints=1),
         "groups_metrics": []},
        {"kind": "quantile", "quantile": 0.5, "threshold": 1.75, "overall": _metrics(10, 0, 0, viewpoints=5),
         "groups_metrics": []},
    ]


def test_sweep_csv(tmp_path):
    path = tmp_path / "s.csv"
    report_files.write_sweep_csv(_sweep(), str(path))
    header, rows = _read(path)
    assert header == list(SWEEP_COLUMNS)
    assert [r["kind"] for r in rows] == ["absolute", "absolute", "quantile"]
    assert rows[0]["quantile"] == "" and float(rows[2]["quantile"]) == 0.5
    assert [float(r["threshold"]) for r in rows] == [1.8, 1.7, 1.75]
    assert float(rows[0]["grasp_success_rate"]) == pytest.approx(0.8)
    assert float(rows[0]["viewpoint_rate"]) == pytest.approx(0.2)
    assert rows[2]["motion_number"] == "" and int(rows[2]["successes"]) == 0
    assert int(rows[1]["attempts"]) == 10


def test_sweep_refuses_bad_kind(tmp_path):
    rows = _sweep()
    rows[1]["kind"] = "relative"
    with pytest.raises(ValueError, match="kind"):
        report_files.write_sweep_csv(rows, str(tmp_path / "s.csv"))


# ----------------------------------------------------------------------------- plots


def _png_size(path):
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


def test_plot_by_objects_writes_png(tmp_path):
    pytest.importorskip("matplotlib")
    path = tmp_path / "fig7.png"
    report_files.plot_by_objects({"gdnet": _report(), "vags": _report("vags")}, str(path), title="t")
    w, h = _png_size(path)
    assert w > 300 and h > 100 and os.path.getsize(path) > 1000


def test_plot_sweep_writes_png(tmp_path):
    pytest.importorskip("matplotlib")
    path = tmp_path / "fig6.png"
    report_files.plot_sweep(_sweep(), str(path))
    w, h = _png_size(path)
    assert w > 300 and h > 100


def test_missing_matplotlib_raises_missing_plot_extra(tmp_path, monkeypatch):
    for name in [m for m in sys.modules if m == "matplotlib" or m.startswith("matplotlib.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # makes `import matplotlib` fail
    with pytest.raises(MissingPlotExtra, match=r"pip install"):
        report_files.check_plot_available()
    with pytest.raises(ValueError, match="matplotlib"):  # MissingPlotExtra is a ValueError
        report_files.plot_by_objects({"a": _report()}, str(tmp_path / "x.png"))
    assert not (tmp_path / "x.png").exists()
    # the CSV writers do not need it
    report_files.write_csv(_report(), str(tmp_path / "r.csv"))


# ----------------------------------------------------------------------------- attempt pictures


H = 24


def _record(direct=True, success=True, **kw):
    rng = np.random.default_rng(0)
    q = rng.uniform(0.0, 2.0, (H, H)).astype(np.float32)
    q[5, 7] = 3.0
    args = dict(
        round_index=2, attempt_index=1, n_objects=3,
        color=rng.integers(0, 255, (H, H, 3), dtype=np.uint8),
        height=rng.uniform(0, 0.1, (H, H)).astype(np.float32),
        q_grasp=q, grasp=np.array([4, 5, 7], np.int32), q_max=np.float32(3.0), threshold=1.78,
        direct=direct, success=success, grasp_world=np.array([0.01, -0.02, 0.03], np.float32),
        yaw=np.float32(0.5), n_rotations=16,
    )
    if not direct:
        args.update(
            q_view=rng.uniform(0, 1, (H, H)).astype(np.float32), view=np.array([10, 12]),
            local_depth=rng.uniform(0.2, 0.3, (30, 40)).astype(np.float32),
            ggcnn_quality=rng.uniform(0, 1, (20, 20)).astype(np.float32),
            ggcnn_angle=rng.uniform(-1.5, 1.5, (20, 20)).astype(np.float32),
            ggcnn_width=rng.uniform(0, 30, (20, 20)).astype(np.float32),
            ggcnn_pixel=np.array([15, 3]), ggcnn_angle_peak=0.3,
        )
    args.update(kw)
    return AttemptRecord(**args)


def _border(img):
    return img[1, img.shape[1] // 2]


def test_attempt_picture_shape_dtype_and_outcome_colour():
    ok = attempt_picture(_record(success=True))
    bad = attempt_picture(_record(success=False))
    assert ok.dtype == np.uint8 and ok.ndim == 3 and ok.shape[2] == 3
    size = record.panel_size(_record())
    assert size == (H * 6, H * 6)  # 24 px heightmap enlarged to >= 128 px
    b = record.BORDER_PX
    assert ok.shape == (2 * size[0] + 3 * b, 3 * size[1] + 4 * b, 3)
    assert tuple(_border(ok)) == SUCCESS_RGB and tuple(_border(bad)) == FAILURE_RGB
    assert tuple(ok[-1, 0]) == SUCCESS_RGB and tuple(bad[-1, -1]) == FAILURE_RGB
    # only the outcome frame differs
    inner = (slice(b, -b), slice(b, -b))
    assert np.array_equal(ok[inner], bad[inner])


def _panel(img, index, size):
    b = record.BORDER_PX
    r, c = divmod(index, 3)
    return img[b + r * (size[0] + b): b + r * (size[0] + b) + size[0],
               b + c * (size[1] + b): b + c * (size[1] + b) + size[1]]


def test_attempt_picture_panels_and_markers():
    rec = _record(direct=True)
    img = attempt_picture(rec)
    size = record.panel_size(rec)
    grey = np.array(record.GREY_RGB, np.uint8)
    # direct grasp: VANet, local depth and GG-CNN panels are grey
    for k in (3, 4, 5):
        assert (_panel(img, k, size) == grey).all()
    # the executed grasp line is drawn on the colour panel through the grasp cell's centre
    s = size[0] // H
    centre = (5 + 0.5) * s, (7 + 0.5) * s  # cell (5, 7)'s centre in panel pixels
    line = np.argwhere((_panel(img, 0, size) == np.array(record.GRASP_RGB, np.uint8)).all(-1))
    # rotation 4 of 16 is 90 deg: the closing axis runs along rows, so the line is vertical
    assert len(np.unique(line[:, 1])) == 1 and abs(line[0, 1] - centre[1]) <= 1
    assert line[:, 0].min() < centre[0] - 8 and line[:, 0].max() > centre[0] + 8
    assert abs(line[:, 0].mean() - centre[0]) <= 1
    # the GDNet panel has a white cross centred on the argmax
    cross = np.argwhere((_panel(img, 2, size) == np.array(record.MARK_RGB, np.uint8)).all(-1))
    assert abs(cross[:, 0].mean() - centre[0]) <= 1 and abs(cross[:, 1].mean() - centre[1]) <= 1
    assert len(np.unique(cross[:, 0])) > 5 and len(np.unique(cross[:, 1])) > 5

    rec2 = _record(direct=False)
    img2 = attempt_picture(rec2)
    for k in (3, 4, 5):
        assert not (_panel(img2, k, size) == grey).all()
    cross = np.argwhere((_panel(img2, 3, size) == np.array(record.MARK_RGB, np.uint8)).all(-1))
    assert abs(cross[:, 0].mean() - 10.5 * s) <= 1 and abs(cross[:, 1].mean() - 12.5 * s) <= 1
    # GG-CNN's peak [u, v] = [15, 3] is column 15, row 3 of its 20 x 20 map (scaled to the panel)
    gs = size[0] / 20
    cross = np.argwhere((_panel(img2, 5, size) == np.array(record.MARK_RGB, np.uint8)).all(-1))
    assert abs(cross[:, 0].mean() - 3.5 * gs) <= 1.5 and abs(cross[:, 1].mean() - 15.5 * gs) <= 1.5
    assert (_panel(img2, 5, size) == np.array(record.GRASP_RGB, np.uint8)).all(-1).any()  # angle line
    # a viewpoint grasp without grasp_cell is not drawn on the colour panel ...
    assert not (_panel(img2, 0, size) == np.array(record.GRASP_RGB, np.uint8)).all(-1).any()
    # ... and is with it
    img3 = attempt_picture(_record(direct=False, grasp_cell=np.array([12.0, 12.0])))
    assert (_panel(img3, 0, size) == np.array(record.GRASP_RGB, np.uint8)).all(-1).any()
    # Rotation 2 of 4 is 90 deg over half a turn (a vertical line) and 180 deg over a whole one.
    for half_turn, vertical in ((True, True), (False, False)):
        img4 = attempt_picture(_record(direct=True, grasp=np.array([2, 5, 7], np.int32), n_rotations=4,
                                       half_turn=half_turn))
        line = np.argwhere((_panel(img4, 0, size) == np.array(record.GRASP_RGB, np.uint8)).all(-1))
        assert len(np.unique(line[:, 1 if vertical else 0])) == 1


def test_write_round_files_and_json(tmp_path):
    recs = [_record(direct=True, success=False, attempt_index=0),
            _record(direct=False, success=True, attempt_index=1)]
    out = tmp_path / "rec" / "w0"
    paths = write_round(str(out), recs)
    names = [os.path.basename(p) for p in paths]
    assert names == ["round002_attempt00.png", "round002_attempt01.png", "round002.json"]
    for p in paths[:2]:
        data = open(p, "rb").read()
        assert data[:8] == b"\x89PNG\r\n\x1a\n"
        # decode the PNG back and compare with the picture
        idat = zlib.decompress(data[data.index(b"IDAT") + 4:data.index(b"IEND") - 8])
        w, h = int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
        raw = np.frombuffer(idat, np.uint8).reshape(h, 1 + 3 * w)[:, 1:].reshape(h, w, 3)
        assert np.array_equal(raw, attempt_picture(recs[paths.index(p)]))
    summary = json.load(open(paths[2]))
    assert summary["round"] == 2
    a0, a1 = summary["attempts"]
    assert a0 == {"attempt": 0, "n_objects": 3, "direct": True, "q_max": 3.0, "threshold": 1.78,
                  "grasp": [4, 5, 7], "view": None, "ggcnn_pixel": None, "ggcnn_angle_peak": None,
                  "success": False, "grasp_world": pytest.approx([0.01, -0.02, 0.03]),
                  "yaw": pytest.approx(0.5)}
    assert a1["direct"] is False and a1["success"] is True
    assert a1["view"] == [10, 12] and a1["ggcnn_pixel"] == [15, 3]
    assert a1["ggcnn_angle_peak"] == pytest.approx(0.3)
    assert all(type(v) is int for v in a1["grasp"])


def test_write_round_refuses_duplicates(tmp_path):
    with pytest.raises(ValueError, match="twice"):
        write_round(str(tmp_path), [_record(), _record()])


@pytest.mark.parametrize("field, value, message", [
    ("color", np.zeros((H, H), np.uint8), r"AttemptRecord\.color must be \(H, W, 3\) uint8"),
    ("color", np.zeros((H, H, 3), np.float32), r"AttemptRecord\.color must be \(H, W, 3\) uint8"),
    ("height", np.zeros((H, H + 1), np.float32), r"AttemptRecord\.height must be \(24, 24\)"),
    ("q_grasp", np.zeros((H, H), np.int32), r"AttemptRecord\.q_grasp"),
    ("grasp", np.array([1, 2]), r"AttemptRecord\.grasp must be \(3,\) int"),
    ("grasp", np.array([16, 2, 2]), r"AttemptRecord\.grasp .* out of range"),
    ("grasp", np.array([1.0, 2.0, 2.0]), r"AttemptRecord\.grasp must be \(3,\) int"),
    ("view", np.array([2, H]), r"AttemptRecord\.view .* out of range"),
    ("grasp_world", np.zeros(2), r"AttemptRecord\.grasp_world must be \(3,\)"),
    ("local_depth", np.zeros(10, np.float32), r"AttemptRecord\.local_depth must be \(H, W\)"),
    ("ggcnn_quality", np.zeros((20, 20), np.float32), r"give all of"),
    ("success", 1, r"AttemptRecord\.success must be a bool"),
    ("round_index", -1, r"AttemptRecord\.round_index must be an int >= 0"),
    ("q_max", None, r"AttemptRecord\.q_max must be a number"),
])
def test_bad_fields_raise_value_error_naming_them(field, value, message):
    with pytest.raises(ValueError, match=message):
        _record(**{field: value})


def test_ggcnn_pixel_bounded_by_its_maps():
    with pytest.raises(ValueError, match=r"ggcnn_pixel .* out of range"):
        _record(direct=False, ggcnn_pixel=np.array([20, 3]))
    with pytest.raises(ValueError, match=r"ggcnn_angle must be \(20, 20\)"):
        _record(direct=False, ggcnn_angle=np.zeros((20, 21), np.float32))
