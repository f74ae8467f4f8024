"""Data-parallel stage 1 (``vags_jax.stages.data_parallel``, ``vags_jax.parallel``) on 2 virtual CPU
devices.  This session's JAX already has one CPU device, so the multi-device checks run in a
subprocess started with ``XLA_FLAGS=--xla_force_host_platform_device_count=2``:
``data_parallel_worker.py`` computes them all in one process (the update and the environment
step, one device against two; train.py --devices 2 run, resumed and run again) for the tests
below to judge, or ``train.py`` itself; they share the session's compile cache (conftest)."""
import json
import os
import socket
import subprocess
import sys

import numpy as np
import pytest

import train
from vags_jax import config as C
from vags_jax.stages import checkpoint

from conftest import TINY_TEST_OVERRIDES

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
WORKER = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data_parallel_worker.py")
TWO_DEVICES = {**os.environ, "XLA_FLAGS": (os.environ.get("XLA_FLAGS", "")
                                           + " --xla_force_host_platform_device_count=2").strip()}


def _two_devices(argv, timeout=900):
    """``argv`` (after the interpreter) run with 2 CPU devices -> CompletedProcess."""
    return subprocess.run([sys.executable] + argv, cwd=ROOT, env=TWO_DEVICES, capture_output=True, text=True,
                          timeout=timeout)


@pytest.fixture(scope="module")
def two_devices(tmp_path_factory) -> dict:
    """``data_parallel_worker.py``'s results ({"update", "env", "train", "out"}), run once."""
    out = str(tmp_path_factory.mktemp("data_parallel"))
    proc = _two_devices([WORKER, out], timeout=1500)
    assert proc.returncode == 0, proc.stderr[-4000:]
    return {**json.loads(proc.stdout.strip().splitlines()[-1]), "out": out}


def _sets(iterations):
    over = {**TINY_TEST_OVERRIDES, "stage1.iterations": iterations}
    return [f"{k}={v}" for k, v in over.items()]


def _rows(path):
    with open(path) as f:
        return [json.loads(line) for line in f]


def test_sharded_update_equals_the_one_device_update(two_devices):
    """A DQN update of GDNet (SGD, BatchNorm in train mode) on a batch of 8 split 4 + 4 over 2
    devices, with pmean'd gradients and BatchNorm statistics, equals the one-device update of
    the 8: parameters, optimizer state, running statistics, loss, gradient norm, TD errors."""
    r = two_devices["update"]
    assert r["params_moved"] > 1e-3 and r["batch_stats_moved"] > 1e-2, r  # the update changed both
    assert r["params"] < 1e-5 and r["target_params"] < 1e-5 and r["opt_state"] < 1e-5, r
    assert r["batch_stats"] < 1e-5, r
    assert r["loss"] < 1e-6 * max(1.0, r["loss_value"]) and r["grad_norm"] < 1e-5 and r["td"] < 1e-5, r


def test_sharded_env_step_equals_the_unsharded_step_per_world(two_devices):
    """One grasp step of 2 worlds (physics, render, heightmaps, bookkeeping) from the same start,
    unsharded and with one world per device in the data-parallel layout.  Per world: the same
    grasp outcome, objects left and attempt count; joint positions within 2e-3, heights within
    5 mm, and the same colour heightmap but at object edges.  Not bit for bit: the per-device program (a batch of 1 under
    shard_map) is compiled apart from the batch of 2, and half a second of contacts in the lift
    grows their rounding differences (measured with elliptic cones: 2.2e-4 in joint positions,
    1.0 mm in heights; one world jitted alone, unsharded, differed from the sharded step by as
    much, 4.9e-4 and 1.5 mm; with the worker's pyramidal cones 1.4e-5 and 4e-6 m).  Resets are not compared: a device's worlds draw new scenes from its own key
    stream, by design.  The start is the 2 worlds of the data-parallel stage that
    ``test_train_py_devices_2_trains_checkpoints_and_resumes`` trains (one program for both)."""
    assert two_devices["stage_programs"] == ["env", "stage1"], two_devices["stage_programs"]
    r = two_devices["env"]
    assert r["success_one"] == r["success_two"] and r["remaining"][0] == r["remaining"][1], r
    assert r["qpos_moved"] > 0.1, r  # the grasp lifted an object
    assert r["qpos"] < 2e-3 and r["height"] < 5e-3 and r["attempts"] == 0, r
    # Colour: equal except on boundaries between surfaces, which a sub-millimetre shift can move
    # across a cell (seen on one 2-core machine: 8 cells), and never in more than 1 % of the cells.
    assert r["color_cells_off_edges"] == 0 and r["color_cells"] <= r["cells"] // 100, r


def test_train_py_devices_2_trains_checkpoints_and_resumes(two_devices):
    """train.py --stage gdnet --devices 2 on 2 CPU devices: 2 iterations, then --resume to 4 (the
    device count kept from config.json), equal to 4 iterations in one go; finite learning
    metrics; the replay saved as 2 shards.  --devices 3 for 2 worlds: one line, exit code 2."""
    out, straight = os.path.join(two_devices["out"], "dp"), os.path.join(two_devices["out"], "dp_straight")
    first, resumed, once = (two_devices["train"][k] for k in ("first", "resumed", "once"))
    assert first["code"] == 0, first["stderr"][-4000:]
    assert "data parallel over 2 devices (1 world each)" in first["stderr"]
    with open(os.path.join(out, "config.json")) as f:
        assert json.load(f)["parallel"]["devices"] == 2
    with open(os.path.join(out, "summary.json")) as f:
        assert json.load(f)["devices"] == 2
    assert checkpoint.checkpoint_steps(out)[-1] == 4  # the first run's 2, and the resumed run's 4
    replay_shapes = checkpoint.part_shapes(out, 4, "replay")
    assert all(s[0] == 2 for s in replay_shapes) and (2, 32) in replay_shapes  # 2 shards of 64 / 2 priorities

    assert resumed["code"] == 0, resumed["stderr"][-4000:]
    rows = _rows(os.path.join(out, "metrics.jsonl"))
    assert [r["iteration"] for r in rows] == [0, 1, 2, 3]
    assert all(r["updates"] > 0 for r in rows) and all(r["attempts"] + r["worlds_resetting"] == 2 for r in rows)
    for name in ("loss", "td_abs", "q_max", "q_executed", "success_rate"):
        assert all(np.isfinite(r[name]) for r in rows), name
    assert rows[-1]["replay_size"] == rows[-1]["attempts_total"]  # both devices' shards counted

    assert once["code"] == 0, once["stderr"][-4000:]
    a, _ = checkpoint.read(out, 4)
    b, _ = checkpoint.read(straight, 4)
    assert a.keys() == b.keys() and all(np.array_equal(a[p][k], b[p][k]) for p in a for k in a[p]), \
        "the resumed data-parallel run diverged from the uninterrupted one"
    drop = lambda rs: [{k: v for k, v in r.items() if k != "wall_s"} for r in rs]  # noqa: E731
    assert drop(rows) == drop(_rows(os.path.join(straight, "metrics.jsonl")))

    # train.main(--devices 3) in the worker's 2-device process (exit code 2 of the command line).
    too_many = two_devices["train"]["too_many"]
    assert too_many["code"] == 2 and too_many["stdout"] == ""
    lines = too_many["stderr"].strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in too_many["stderr"], too_many["stderr"]
    assert not os.path.exists(os.path.join(two_devices["out"], "three"))  # refused before writing anything
    assert "stage1.n_worlds = 2 is not divisible by the 3 devices" in lines[0]


@pytest.mark.parametrize("argv, message", [
    (["--stage", "gdnet", "--devices", "1", "--resume"], "trained on 2 device(s)"),
    (["--stage", "gdnet", "--devices", "all", "--resume"], "trained on 2 device(s)"),  # all = 1 here
    (["--resume"], "trains stage 1 data-parallel on 2 devices"),
    (["--stage", "stage2"], "trains stage 1 data-parallel on 2 devices"),
])
def test_a_data_parallel_run_refuses_another_device_count_and_stages_2_3(tmp_path, capsys, argv, message):
    """A run recorded as trained on 2 devices (its config.json) refuses another count and stages
    2-3 in one line naming what to do, before reading any checkpoint or compiling."""
    out = tmp_path / "run"
    out.mkdir()
    checkpoint.save_config(str(out), C.replace(C.tiny(), **C.parse_overrides(_sets(2) + ["parallel.devices=2"])))
    assert train.main(["--out", str(out)] + argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err


@pytest.mark.parametrize("argv, message", [
    (["--config", "tiny", "--devices", "2"], "the whole pipeline (GG-CNN, stages 2 and 3) runs on one device"),
    (["--config", "tiny", "--stage", "vpg", "--devices", "2"], "covers stage 1 only"),
    (["--config", "tiny", "--stage", "ggcnn", "--devices", "2"], "--devices apply to --stage gdnet only"),
    (["--config", "tiny", "--stage", "gdnet", "--devices", "2", "--set", "parallel.devices=4"], "disagree"),
    (["--config", "tiny", "--stage", "gdnet", "--devices", "2"], "asks for more devices than the 1 cpu"),
    (["--config", "tiny", "--stage", "gdnet", "--devices", "0"], "must be a positive int or 'all'"),
])
def test_devices_flag_errors(tmp_path, capsys, argv, message):
    """--devices where data parallelism does not reach yet, or beyond this process's one CPU
    device: one line, exit code 2, before anything is built."""
    try:
        code = train.main(argv + ["--out", str(tmp_path / "run")])
    except SystemExit as e:  # argparse
        code = e.code
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err


def test_distributed_initialises_before_jax_starts(tmp_path):
    """--distributed as the one process of a local "cluster" (JAX_COORDINATOR_ADDRESS,
    JAX_NUM_PROCESSES=1, JAX_PROCESS_ID=0): jax.distributed.initialize() succeeds (it must come
    before JAX touches a device), then --devices counts the devices it sees; without a
    cluster's environment it is one line saying what to set."""
    with socket.socket() as s:
        s.bind(("localhost", 0))
        port = s.getsockname()[1]
    argv = [sys.executable, "train.py", "--distributed", "--config", "tiny", "--stage", "gdnet", "--devices", "2",
            "--out", str(tmp_path / "run")]
    env = {k: v for k, v in os.environ.items() if not k.startswith(("JAX_COORDINATOR", "JAX_NUM_PROC", "JAX_PROCESS"))}
    alone = subprocess.run(argv, cwd=ROOT, env={**env, "JAX_COORDINATOR_ADDRESS": f"localhost:{port}",
                                                "JAX_NUM_PROCESSES": "1", "JAX_PROCESS_ID": "0"},
                           capture_output=True, text=True, timeout=300)
    assert alone.returncode == 2 and "asks for more devices than the 1 cpu" in alone.stderr, alone.stderr
    bare = subprocess.run(argv, cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    lines = bare.stderr.strip().splitlines()
    assert bare.returncode == 2 and len(lines) == 1 and "jax.distributed.initialize() failed" in lines[0], lines


def test_resolve_counts_gpus_as_it_counts_cpu_devices(monkeypatch):
    """``--devices`` on GPUs: "all" is every GPU, a number up to them is taken (on 2 H100s stage 1
    learned as on one over 40 iterations, bench/RESULTS.md), more is one line naming what there is."""
    import types

    from vags_jax.parallel import mesh

    for platform in ("gpu", "cpu"):
        monkeypatch.setattr(mesh.jax, "devices", lambda *a, p=platform: [types.SimpleNamespace(platform=p)] * 2)
        monkeypatch.setattr(mesh.jax, "device_count", lambda *a: 2)
        assert mesh.resolve(1) == 1 and mesh.resolve(2) == 2 and mesh.resolve("all") == 2
        with pytest.raises(ValueError, match=f"more devices than the 2 {platform} device"):
            mesh.resolve(3)
