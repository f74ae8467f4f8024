"""What train.py says while it runs and at its end (stages/progress.py), on hand-made inputs."""
import importlib.util
import math

import jax
import jax.numpy as jnp
import pytest

from vags_jax.stages import progress


def test_duration_and_eta_by_hand():
    assert progress.duration(4.24) == "4.2 s"
    assert progress.duration(185) == "3 min 05 s"
    assert progress.duration(2 * 3600 + 7 * 60 + 10) == "2 h 07 min"
    assert progress.duration(math.nan) == "?"
    # 6 iterations took 3 s after compiling: 0.5 s each, 10 left -> 5 s.
    assert progress.eta(10, 3.0, 6) == pytest.approx(5.0)
    assert progress.eta(10, 0.0, 0) is None


def test_compile_step_counts_compiling_once():
    said = []
    # Enough work that compiling it takes well over compile_step's 0.05 s (a lone cumsum took
    # 0.044 s on 2 cores with the suite's XLA flags, and was then reported as already compiled).
    f = jax.jit(lambda x: sum(jnp.cumsum(jnp.sin(x * (i + 1.0))) for i in range(40)) - 1.0)
    with progress.compile_step("a cumsum", said.append) as clock:
        f(jnp.arange(5.0)).block_until_ready()
    assert clock.seconds > 0 and said[0] == "compiling a cumsum ..." and said[1].startswith("compiled a cumsum in ")
    with progress.compile_step("a cumsum", said.append) as again:
        f(jnp.arange(5.0)).block_until_ready()
    assert again.seconds == 0 and said[3].startswith("a cumsum: already compiled in this process")
    with progress.compile_step("silent", None):  # no log: no lines
        f(jnp.arange(5.0))
    assert len(said) == 4


def test_scalars_keep_finite_numbers_tagged_by_stage():
    row = {"stage": "stage2", "iteration": 7, "wall_s": 3.2, "loss_vanet": 0.25, "success_rate": 0.5,
           "q_max": math.inf, "grasp_attempts": 12, "note": "text", "flag": True}
    assert progress.scalars(row) == {"stage2/loss_vanet": 0.25, "stage2/success_rate": 0.5,
                                     "stage2/grasp_attempts": 12.0}
    assert progress.scalars({"step": 10, "loss": 1.5}) == {"train/loss": 1.5}


def test_closing_lines_and_next_commands():
    s1 = {"stage": "stage1", "iterations": 8, "grasp_attempts": 14, "recent_success_rate": 0.25, "wall_s": 65.0,
          "out": "runs/a"}
    s2 = {"stage": "stage2", "iterations": 2, "grasp_attempts": 4, "recent_success_rate": None, "threshold": 1.5,
          "wall_s": 3.0, "out": "runs/a/stage2"}
    lines = progress.closing_lines([s1, s2], "runs/a", {"stage1": "8/8", "stage2": "2/2", "stage3": "4/4"}, 70.0,
                                   "runs/a/summary.json", True)
    assert lines[0] == "trained in 1 min 10 s: runs/a"
    assert "stage1" in lines[1] and "1 min 05 s" in lines[1] and "recent success 25.0 %" in lines[1]
    assert "recent success -" in lines[2] and "threshold 1.5000" in lines[2] and lines[2].endswith("-> runs/a/stage2")
    assert lines[3] == "  progress: stage1 8/8, stage2 2/2, stage3 4/4"
    assert any(l.strip().startswith("python eval.py --run runs/a  ") for l in lines)
    only1 = progress.next_commands("runs/b", {"stage1": "8/8", "stage2": "0/2", "stage3": "0/4"}, True)
    assert only1[0].startswith("python eval.py --run runs/b ") and "--stage stage2" in only1[1]
    gg = progress.next_commands("runs/c", {"ggcnn": "1/0", "stage1": "0/8"}, True)
    assert gg == ["python eval.py --run runs/c --policy ggcnn    # GG-CNN from the global view"]
    assert progress.next_commands("runs/d", {"stage1": "4/8"}, False)[0].startswith("python train.py --out runs/d --resume")
    assert not any("--rounds 4" in c for c in only1)  # the full benchmark only, off a CPU
    on_cpu = progress.next_commands("runs/b", {"stage1": "8/8", "stage2": "2/2", "stage3": "4/4"}, True, quick=True)
    assert on_cpu[0].startswith("python eval.py --run runs/b --groups 1-3 --rounds 4 ") and "30 min" in on_cpu[0]
    assert on_cpu[1].startswith("python eval.py --run runs/b  ")  # the full benchmark is still offered
    assert progress.next_commands("runs/d", {"stage1": "4/8"}, False, quick=True)[0].startswith("python train.py")
    on_gpu = progress.closing_lines([s1], "runs/a", {"stage1": "8/8"}, 70.0, "runs/a/summary.json", True, peak_gib=50.35)
    assert on_gpu[0] == "trained in 1 min 10 s: runs/a (peak device memory 50.4 GiB)"


@pytest.mark.skipif(importlib.util.find_spec("tensorboardX") is not None, reason="the tensorboard extra is installed")
def test_tensorboard_without_the_extra_is_one_clear_line():
    with pytest.raises(ValueError, match=r"--tensorboard needs tensorboardX, which is not installed: pip install "
                                         r"'vags_jax\[tensorboard\]'"):
        progress.check_tensorboard("runs/tb")
    progress.check_tensorboard(None)  # not asked for: nothing to check


@pytest.mark.skipif(importlib.util.find_spec("tensorboardX") is None, reason="needs the tensorboard extra")
def test_board_writes_the_scalars_as_tensorboard_events(tmp_path):
    import glob
    import struct

    from tensorboardX.proto import event_pb2

    board = progress.Board(str(tmp_path))
    board.rows([{"stage": "stage1", "iteration": 0, "loss": 0.5, "wall_s": 1.0},
                {"stage": "stage1", "iteration": 1, "loss": 0.25, "wall_s": 2.0}])
    board.rows([{"stage": "ggcnn", "step": 10, "loss": 1.5}], step_key="step")
    board.close()
    (path,) = glob.glob(str(tmp_path / "events.*"))
    data, i, got = open(path, "rb").read(), 0, []
    while i < len(data):  # TFRecord: length (8 bytes), its CRC (4), the Event, its CRC (4)
        n = struct.unpack("<Q", data[i:i + 8])[0]
        event = event_pb2.Event()
        event.ParseFromString(data[i + 12:i + 12 + n])
        i += 16 + n
        got += [(event.step, v.tag, v.simple_value) for v in event.summary.value]
    assert got == [(0, "stage1/loss", 0.5), (1, "stage1/loss", 0.25), (10, "ggcnn/loss", 1.5)]
