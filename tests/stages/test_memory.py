"""The memory lower bound checked before training compiles (stages/memory.py), by hand."""
import pytest

from vags_jax import config as C
from vags_jax.stages import memory


def test_stage_bytes_by_hand():
    cfg = C.replace(C.tiny(), **{"workspace.heightmap_px": 32, "camera.width": 128, "camera.height": 96,
                                 "replay.capacity": 64, "stage1.n_worlds": 3, "stage2.n_worlds": 5,
                                 "net.n_rotations": 16, "grasp.n_rotations": 16})
    # stage 1: replay 64 x 10 bytes x 32 x 32; Q maps 3 x 16 x 32 x 32 x 4 bytes; depth 3 x 128 x 96 x 4 bytes.
    assert memory.stage_bytes(cfg, "stage1") == 655_360 + 196_608 + 147_456
    # stages 2 and 3: two replays and GDNet's Q maps twice (global and fused views).
    assert memory.stage_bytes(cfg, "stage2") == 2 * 655_360 + 2 * 327_680 + 245_760


def test_check_fits_names_the_first_stage_that_cannot():
    cfg = C.replace(C.tiny(), **{"stage2.n_worlds": 10_000, "replay.capacity": 10_000})
    need2 = memory.stage_bytes(cfg, "stage2")
    assert memory.stage_bytes(cfg, "stage1") < need2
    memory.check_fits(cfg, ("stage1", "stage2"), need2)  # exactly enough
    memory.check_fits(cfg, ("stage1", "stage2"), None)  # unknown device memory: no check
    with pytest.raises(ValueError, match=r"^stage2: 10,000 worlds need at least .* lower stage2\.n_worlds"):
        memory.check_fits(cfg, ("ggcnn", "stage1", "stage2"), need2 - 1)


class _Device:
    def __init__(self, stats):
        self.stats = stats

    def memory_stats(self):
        return self.stats


def test_peak_is_logged_where_the_device_reports_it(tmp_path, monkeypatch):
    import json

    from vags_jax.stages import driver
    monkeypatch.setattr(memory.jax, "devices", lambda: [_Device({"peak_bytes_in_use": 3 * memory.GIB // 2})])
    assert memory.peak_gib() == 1.5
    driver.log_timing(str(tmp_path), "stage1", 0, 4, 12.34, "done")
    monkeypatch.setattr(memory.jax, "devices", lambda: [_Device(None)])  # a CPU reports nothing
    assert memory.peak_gib() is None
    driver.log_timing(str(tmp_path), "stage2", 0, 2, 1.0, "done")
    rows = [json.loads(line) for line in open(tmp_path / "timings.jsonl")]
    assert rows[0]["peak_device_gib"] == 1.5 and rows[0]["wall_s"] == 12.3
    assert "peak_device_gib" not in rows[1]


def test_the_closing_summary_carries_the_peak(tmp_path, monkeypatch, capsys):
    import argparse
    import json

    from vags_jax import config as C
    from vags_jax.stages import driver
    args = argparse.Namespace(out=str(tmp_path), json=False)
    summary = {"stage": "stage1", "iterations": 0, "grasp_attempts": 0, "recent_success_rate": None, "wall_s": 1.0,
               "out": str(tmp_path)}
    monkeypatch.setattr(memory.jax, "devices", lambda: [_Device({"peak_bytes_in_use": 2 * memory.GIB})])
    driver.report_end(args, summary, [summary], C.tiny(), 1.0, True)
    assert json.load(open(tmp_path / "summary.json"))["peak_device_gib"] == 2.0
    assert "(peak device memory 2.0 GiB)" in capsys.readouterr().out.splitlines()[0]
    assert "peak_device_gib" not in summary  # the caller's dict is left as it was
