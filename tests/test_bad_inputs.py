"""Bad inputs: every one ends in a one-line error naming what to fix, before anything is compiled.

Classes covered (each a parametrised test): ``--set`` config values, Python config
constructors, train.py flags, eval.py flags, damaged or foreign run directories (under
``train.py --resume`` and ``eval.py --run``), real RGB-D frames (``heightmap_from_frame``),
and non-finite training metrics.  The command lines run in-process (``main(argv)``); a few run
as real subprocesses to check exit code 2, one stderr line and no traceback.  Every test
fails if JAX compiles anything while it runs (``no_compiling``), so each error provably comes
before any compiling.
"""
import json
import math
import os
import re
import shutil
import subprocess
import sys
import warnings

import jax
import numpy as np
import pytest

import eval as eval_cli
import train
from vags_jax.perception import camera, heightmap
from vags_jax.stages import checkpoint, driver, requests, stage1 as stages
from vags_jax import config as C
from vags_jax.config import Workspace

from conftest import TINY_TEST_OVERRIDES

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# ----------------------------------------------------------------------------- no compiling

_compiles: list = []
_recording = [False]


def _listener(name, *_, **__):
    if _recording[0] and name == "/jax/core/compile/backend_compile_duration":
        _compiles.append(name)


jax.monitoring.register_event_duration_secs_listener(_listener)


ALLOWED_TO_COMPILE = {"test_numpy_poses_match_the_camera_module",  # checks the tests' own helpers
                      "test_eval_without_viewpoints_plans_without_a_gate_table",  # loads networks: a valid plan
                      "test_eval_out_of_memory_is_one_line_saying_what_to_lower"}  # valid inputs; fails while playing


@pytest.fixture(autouse=True)
def no_compiling(request):
    """Fails the test if XLA compiled anything while it ran."""
    _compiles.clear()
    _recording[0] = request.node.originalname not in ALLOWED_TO_COMPILE
    yield
    _recording[0] = False
    assert not _compiles, f"{len(_compiles)} XLA compilation(s) ran before the error"


def _one_line(err: str) -> str:
    lines = [l for l in err.splitlines() if l.strip()]
    assert len(lines) == 1, f"expected one line on stderr, got {len(lines)}:\n{err}"
    assert "Traceback" not in err
    return lines[0]


def _cli(main, argv, capsys):
    """Runs a CLI main(argv) in-process -> (exit code, its one stderr line)."""
    try:
        code = main(argv)
    except SystemExit as e:  # argparse
        code = e.code
    return code, _one_line(capsys.readouterr().err)


# ----------------------------------------------------------------------------- --set values

SET_CASES = [
    # types (checked from the annotations, vags_jax/config/validation.py)
    ("exploration.daes=maybe", r"exploration\.daes must be true or false, got 'maybe'"),
    ("exploration.daes=1", r"exploration\.daes must be true or false, got 1 \(int\)"),
    ("camera.noise.enabled=yes", r"camera\.noise\.enabled must be true or false"),
    ("sim.sleep=0", r"sim\.sleep must be true or false"),
    ("dqn.double_q=null", r"dqn\.double_q must be true or false, got None"),
    ("stage1.n_worlds=true", r"stage1\.n_worlds must be an int, got True \(bool\)"),
    ("stage1.iterations=2.5", r"stage1\.iterations must be an int, got 2\.5 \(float\)"),
    ("stage1.iterations=abc", r"stage1\.iterations must be an int, got 'abc'"),
    ("stage1.iterations=[4]", r"stage1\.iterations must be an int"),
    ("replay.capacity=1e9", r"replay\.capacity must be an int.*without a decimal point or exponent: 1000000000"),
    ("replay.capacity=1e3", r"replay\.capacity must be an int.*: 1000$"),
    ("workspace.heightmap_px=64.0", r"workspace\.heightmap_px must be an int, got 64\.0"),
    ("sim.iterations=1e1", r"sim\.iterations must be an int"),
    ("sim.njmax=2.5", r"sim\.njmax must be null or an int, got 2\.5"),
    ("seed=1.5", r"seed must be an int, got 1\.5"),
    ("dqn.learning_rate=Infinity", r"dqn\.learning_rate must be a finite number, got inf"),
    ("dqn.learning_rate=-Infinity", r"dqn\.learning_rate must be a finite number, got -inf"),
    ("dqn.learning_rate=NaN", r"dqn\.learning_rate must be a finite number, got nan"),
    ("workspace.table_z=NaN", r"workspace\.table_z must be a finite number"),
    ("scene.friction=true", r"scene\.friction must be a finite number, got True \(bool\)"),
    ("scene.friction=high", r"scene\.friction must be a finite number, got 'high'"),
    ("grasp.descent_clearance=none", r"grasp\.descent_clearance must be null or a finite number, got 'none'"),
    ("net.trunk=3", r"net\.trunk must be a string, got 3"),
    ("net.init=densenet121.npz", r"net\.init loads ImageNet weights into DenseNet-121 trunks; set net\.trunk=densenet121"),
    ("net.init=3", r"net\.init must be null or a string, got 3"),
    ("workspace.center=[0.1]", r"workspace\.center must be a list of 2 items.*needs 2"),
    ("workspace.center=[0, 0, 0]", r"workspace\.center must be a list of 2 items"),
    ("workspace.center=0.1", r"workspace\.center must be a list of 2 items"),
    ('workspace.center=[0, "a"]', r"workspace\.center\[1\] must be a finite number, got 'a'"),
    ("workspace.center=[0, NaN]", r"workspace\.center\[1\] must be a finite number"),
    ("camera.global_position=[0, 0]", r"camera\.global_position must be a list of 3 items"),
    ("scene.shapes=cube", r"scene\.shapes must be a list of strings, got 'cube'"),
    ('scene.shapes=["cube", 3]', r"scene\.shapes\[1\] must be a string, got 3"),
    ("dqn=3", r"dqn must be a DQN section, got 3"),
    # ranges
    ("dqn.learning_rate=0", r"dqn\.learning_rate must be > 0, got 0\.0"),
    ("dqn.learning_rate=2", r"dqn\.learning_rate must be in \(0, 1\]"),
    ("scene.friction=-1", r"scene\.friction must be in \(0, 10\], got -1"),
    ("scene.friction=0", r"scene\.friction must be in \(0, 10\]"),
    ("workspace.heightmap_px=100000", r"workspace\.heightmap_px must be in \[8, 1,024\]"),
    ("workspace.heightmap_px=4", r"workspace\.heightmap_px must be an int >= 8"),
    ("workspace.size=0", r"workspace\.size must be > 0"),
    ("workspace.size=-0.4", r"workspace\.size must be > 0"),
    ("workspace.size=50", r"workspace\.size must be in \(0, 5\]"),
    ("workspace.center=[100, 0]", r"workspace\.center must be in \[-10, 10\]"),
    ("scene.max_objects=0", r"scene\.max_objects must be an int >= 1"),
    ("scene.shapes=[]", r"scene\.shapes must name at least one shape"),
    ("scene.copies_per_shape=0", r"scene\.copies_per_shape must be >= 1"),
    ("scene.drop_height=0", r"scene\.drop_height must be in \(0, 1\]"),
    ("scene.settle_time=-1", r"scene\.settle_time must be >= 0"),
    ("scene.settle_time=1000", r"scene\.settle_time must be in \[0, 10\]"),
    ("scene.object_density=0", r"scene\.object_density must be in \(0, "),
    ("scene.drop_margin=0.3", r"scene\.drop_margin \(0\.3 m\) must be less than half of workspace\.size"),
    ("sim.impl=cuda", r"sim\.impl must be 'jax' or 'warp'"),
    ("sim.timestep=0", r"sim\.timestep must be in \(0, 0\.01\]"),
    ("sim.timestep=0.1", r"sim\.timestep must be in \(0, 0\.01\]"),
    ("sim.iterations=0", r"sim\.iterations must be >= 1"),
    ("sim.ls_iterations=100000", r"sim\.ls_iterations must be in \[1, 1,000\]"),
    ("sim.solver=pgs", r"sim\.solver must be 'newton' or 'cg'"),
    ("sim.tolerance=1", r"sim\.tolerance must be in \[0, 1\)"),
    ("sim.impratio=0", r"sim\.impratio must be in \(0, "),
    ("sim.contacts_per_world=0", r"sim\.contacts_per_world must be in \[1, "),
    ("sim.naconmax=-5", r"sim\.naconmax must be in \[1, "),
    ("sim.sleep_tolerance=0", r"sim\.sleep_tolerance must be > 0"),
    ("grasp.n_rotations=0", r"grasp\.n_rotations must be a positive int"),
    ("grasp.n_rotations=12", r"net\.n_rotations must equal grasp\.n_rotations"),
    ("grasp.t_close=0", r"grasp\.t_close must be > 0 seconds"),
    ("grasp.t_lift=100", r"grasp\.t_lift must be in \(0, 10\] seconds"),
    ("grasp.lift_hold=1", r"grasp\.lift_hold must be in \[0, 1\)"),
    ("grasp.finger_stroke=-0.01", r"grasp\.finger_stroke must be > 0"),
    ("grasp.success_lift=0.5", r"grasp\.success_lift must be in \(0, lift_height = 0\.15\)"),
    ("grasp.closed_gap=0.1", r"grasp\.closed_gap must be in \[0, 0\.085\)"),
    ("grasp.grip_force=0", r"grasp\.grip_force must be in \(0, "),
    ("grasp.descent_clearance=0.001", r"grasp\.descent_clearance must be null/None .* \[0\.005"),
    ("grasp.approach_height=0", r"grasp\.approach_height must be in \(0, 1\]"),
    ("camera.width=4", r"Camera image must be at least 8 x 8 pixels"),
    ("camera.width=5000", r"camera\.width must be in \[8, 4,096\] pixels, got 5,000"),
    ("camera.width=100000", r"camera\.width must be in \[8, 4,096\] pixels, got 100,000"),
    ("camera.render_batch=200000", r"camera\.render_batch = 200000 images of 128 x 96 overflow .* use at most 174762$"),
    ("camera.height=480.5", r"camera\.height must be an int"),
    ("camera.fx=0", r"camera\.fx and Camera\.fy must be > 0"),
    ("camera.near=0", r"Camera needs 0 < near < far"),
    ("camera.near=3", r"Camera needs 0 < near < far"),
    ("camera.far=1000", r"camera\.far must be in \(0, 100\]"),
    ("camera.cx=-5", r"camera\.cx must be in \[0, 128\]"),
    ("camera.global_position=[0, 0, -1]", r"camera\.global_position .* must be above the table"),
    ("camera.global_target=[0, -0.42, 0.62]", r"camera\.global_position .* and global_target .* must differ"),
    ("camera.viewpoint_height=0.01", r"camera\.viewpoint_height must be in \(0\.05, 2\)"),
    ("camera.renderer=opengl", r"camera\.renderer must be 'jax' or 'warp'"),
    ("camera.render_batch=0", r"camera\.render_batch must be >= 1"),
    ("camera.noise.dropout_prob=1.5", r"camera\.noise\.dropout_prob must be in \[0, 1\]"),
    ("camera.noise.grazing_dropout_deg=120", r"camera\.noise\.grazing_dropout_deg must be in \(0, 90\]"),
    ("camera.noise.sigma_base=-0.001", r"camera\.noise\.sigma_base must be in \[0, "),
    ("net.trunk=resnet", r"net\.trunk must be 'densenet121' or 'small'"),
    ("net.dtype=float16", r"net\.dtype must be float32 or bfloat16"),
    ("net.head_channels=0", r"net\.head_channels must be in \[1, "),
    ("net.small_width=-8", r"net\.small_width must be in \[1, "),
    ("dqn.gamma=1", r"dqn\.gamma must be in \[0, 1\)"),
    ("dqn.optimizer=rmsprop", r"dqn\.optimizer must be 'sgd' or 'adam'"),
    ("dqn.batch_size=0", r"dqn\.batch_size must be >= 1"),
    ("dqn.batch_size=100000", r"dqn\.batch_size must be in \[1, 4,096\]"),
    ("dqn.momentum=1", r"dqn\.momentum must be in \[0, 1\)"),
    ("dqn.weight_decay=-0.1", r"dqn\.weight_decay must be in \[0, 1\)"),
    ("dqn.target_update_period=0", r"dqn\.target_update_period must be >= 1"),
    ("dqn.huber_delta=0", r"dqn\.huber_delta must be in \(0, "),
    ("replay.alpha=1.5", r"replay\.alpha must be in \[0, 1\]"),
    ("replay.beta=-0.1", r"replay\.beta must be in \[0, 1\]"),
    ("replay.priority_eps=0", r"replay\.priority_eps must be in \(0, 1\]"),
    ("replay.capacity=0", r"replay\.capacity must be >= 1"),
    ("replay.capacity=1000000000", r"replay\.capacity = 1,000,000,000 transitions of 32 x 32 heightmaps need "
                                   r"9,537 GiB.*at most 13,421,772"),
    ("exploration.eps_start=1.5", r"Exploration needs 0 <= eps_end <= eps_start <= 1"),
    ("exploration.eps_end=0.9", r"Exploration needs 0 <= eps_end <= eps_start <= 1"),
    ("exploration.eps_decay=0", r"exploration\.eps_decay must be in \(0, 1\]"),
    ("exploration.height_threshold=-0.01", r"exploration\.height_threshold must be in \[0, 1\)"),
    ("stage1.n_worlds=0", r"stage1\.n_worlds must be >= 1"),
    ("stage1.n_worlds=2000000", r"stage1\.n_worlds must be in \[1, 1,048,576\]"),
    ("stage1.iterations=0", r"stage1\.iterations must be >= 1"),
    ("stage1.iterations=-3", r"stage1\.iterations must be >= 1"),
    ("stage1.iterations=3000000000", r"overflow the int32 attempt counter"),
    ("stage1.min_objects=0", r"Stage needs 1 <= min_objects <= max_objects"),
    ("stage1.max_objects=7", r"stage1\.max_objects \(7\) exceeds scene\.max_objects \(3\)"),
    ("stage1.updates_per_iteration=0", r"stage1\.updates_per_iteration must be in \[1, "),
    ("stage1.learning_starts=-1", r"stage1\.learning_starts must be in \[0, "),
    ("stage1.learning_starts=100000", r"stage1\.learning_starts \(100000\) exceeds replay\.capacity \(512\)"),
    ("stage1.n_worlds=600", r"stage1\.n_worlds \(600\) exceeds replay\.capacity \(512\): one iteration adds up to "
                            r"one transition per world"),
    ("stage1.max_attempts_extra=-1", r"stage1\.max_attempts_extra must be in \[0, 1,000\]"),
    ('stage1.name=" "', r"stage1\.name must not be empty"),
    ("seed=-1", r"seed must be in \[0, 4,294,967,295\]"),
    ("seed=99999999999", r"seed must be in \[0, 4,294,967,295\]"),
    # names and syntax
    ("dqn.gama=0.3", r"unknown config field 'dqn\.gama' for DQN; valid fields: .*'gamma'"),
    ("foo.bar=1", r"unknown config section 'foo' in Config; sections: "),
    ("stage1.iterations.x=1", r"unknown config section 'stage1\.iterations'"),
    ("camera.noise.foo=2", r"unknown config field 'camera\.noise\.foo' for DepthNoise"),
    ("stage1.iterations", r"must look like section\.field=value"),
]


@pytest.mark.parametrize("item,msg", SET_CASES, ids=[c[0] for c in SET_CASES])
def test_set_value_is_refused_with_the_field_named(item, msg):
    with pytest.raises(ValueError, match=msg):
        C.replace(C.tiny(), **C.parse_overrides([item]))


@pytest.mark.parametrize("items,msg", [
    (["stage1.n_worlds=100000", "workspace.heightmap_px=1024"],
     r"stage1\.n_worlds = 100,000 worlds need Q maps of 16 x 1024 x 1024 each, 3,125 GiB"),
    (["stage1.iterations=2", "stage1.iterations=3"], r"'stage1\.iterations' is given twice \(2 and 3\)"),
    (["camera.width=100000", "camera.height=100000"], r"camera\.width must be in \[8, 4,096\] pixels, got 100,000$"),
])
def test_set_combinations(items, msg):
    with pytest.raises(ValueError, match=msg):
        C.replace(C.tiny(), **C.parse_overrides(items))


def test_good_set_values_are_normalised():
    """The checks let valid spellings through: an int for a float field is stored as a float,
    a JSON list as a tuple, null for an Optional field."""
    cfg = C.replace(C.tiny(), **C.parse_overrides(
        ["scene.friction=1", "workspace.center=[0.1, 0]", "sim.njmax=null", "replay.capacity=1000"]))
    assert type(cfg.scene.friction) is float and cfg.workspace.center == (0.1, 0.0)
    assert cfg.sim.njmax is None and cfg.replay.capacity == 1000
    hash(cfg)  # still usable as a static jit argument


# ----------------------------------------------------------------------------- Python constructors

@pytest.mark.parametrize("make,msg", [
    (lambda: C.Workspace(heightmap_px=True), r"Workspace\.heightmap_px must be an int, got True"),
    (lambda: C.Workspace(center=(0.0, float("inf"))), r"Workspace\.center\[1\] must be a finite number"),
    (lambda: C.Camera(width=np.float32(64)), r"Camera\.width must be an int"),
    (lambda: C.DepthNoise(dropout_prob=-0.5), r"DepthNoise\.dropout_prob must be in \[0, 1\]"),
    (lambda: C.Stage(n_worlds="4"), r"Stage\.n_worlds must be an int, got '4'"),
    (lambda: C.Config(scene={"max_objects": 3}), r"Config\.scene must be a Scene section"),
], ids=["heightmap_px-bool", "center-inf", "width-float32", "noise-dropout", "n_worlds-str", "scene-dict"])
def test_config_constructors_check_types(make, msg):
    with pytest.raises(ValueError, match=msg):
        make()


def test_numpy_ints_are_accepted_as_ints():
    assert type(C.Stage(n_worlds=np.int64(8)).n_worlds) is int


# ----------------------------------------------------------------------------- train.py flags

def _fresh_out(tmp_path):
    return str(tmp_path / "out")


TRAIN_FLAG_CASES = [
    (["--chunk", "-5"], r"argument --chunk: must be an int >= 1"),
    (["--chunk", "0"], r"argument --chunk: must be an int >= 1"),
    (["--chunk", "abc"], r"argument --chunk: must be an int, got 'abc'"),
    (["--chunk", "2.5"], r"argument --chunk: must be an int, got '2\.5'"),
    (["--checkpoint-every", "0"], r"argument --checkpoint-every: must be an int >= 1"),
    (["--checkpoint-every", "-1"], r"argument --checkpoint-every: must be an int >= 1"),
    (["--checkpoint-minutes", "0"], r"argument --checkpoint-minutes: must be a finite number > 0"),
    (["--stage", "ggcnn", "--checkpoint-minutes", "1"], r"--checkpoint-minutes apply to --stage gdnet only"),
    (["--cache-dir", "/proc/version"], r"--cache-dir '/proc/version': cannot create it .*writable directory or 'off'"),
    (["--max-minutes", "0"], r"argument --max-minutes: must be a finite number > 0"),
    (["--max-minutes", "-1"], r"argument --max-minutes: must be a finite number > 0"),
    (["--max-minutes", "nan"], r"argument --max-minutes: must be a finite number > 0"),
    (["--max-minutes", "inf"], r"argument --max-minutes: must be a finite number > 0"),
    (["--max-minutes", "soon"], r"argument --max-minutes: must be a number, got 'soon'"),
    (["--bogus"], r"unrecognized arguments: --bogus"),
    (["--config", "nope"], r"unknown config preset 'nope'"),
    (["--set", "exploration.daes=maybe"], r"exploration\.daes must be true or false"),
    (["--set", "stage1.n_worlds=true"], r"stage1\.n_worlds must be an int, got True"),
    (["--set", "scene.shapes=[\"cube\", \"nope\", \"cube_half\"]"], r"unknown shape 'nope'"),
    (["--set", "dqn.learning_rate=Infinity"], r"dqn\.learning_rate must be a finite number"),
    (["--set", "noequals"], r"must look like section\.field=value"),
    (["--resume", "--config", "tiny"], r"--resume takes the run's own config\.json; drop --config"),
    (["--resume"], r"run directory .* does not exist; drop --resume"),
    (["--config", ""], r"unknown config preset ''; choose one of"),
    (["--config", "", "--stage", "gdnet"], r"unknown config preset ''"),
    (["--tensorboard", ""], r"--tensorboard must not be empty"),
    (["--set", "camera.renderer=warp"], r"camera\.renderer=warp needs (an NVIDIA GPU, but JAX runs on cpu|warp-lang)"),
    (["--stage", "ggcnn", "--set", "camera.renderer=warp"], r"camera\.renderer=warp needs"),
    (["--set", "vags.gate=rate", "gate_table.worlds=0"], r"vags\.gate=rate needs the table train\.py measures after "
     r"stage 3, but gate_table\.worlds=0 skips it: set gate_table\.worlds to at least 1"),
    (["--stage", "gdnet", "--set", "vags.gate=rate", "gate_table.worlds=0"], r"vags\.gate=rate needs the table"),
    (["--set", "gate_table.steps=0"], r"gate_table\.steps must be in \[1, 1,000\], got 0"),
]


@pytest.mark.parametrize("argv,msg", TRAIN_FLAG_CASES, ids=[" ".join(c[0]) for c in TRAIN_FLAG_CASES])
def test_train_flag_is_refused_before_anything_is_written(argv, msg, tmp_path, capsys):
    out = _fresh_out(tmp_path)
    code, line = _cli(train.main, ["--out", out, "--quiet"] + argv, capsys)
    assert code == 2 and line.startswith("train.py: error: ")
    assert re.search(msg, line), line
    assert not os.path.exists(out), "nothing may be written to --out before the inputs are valid"


def test_a_world_count_that_cannot_fit_is_refused_before_compiling(tmp_path, capsys, monkeypatch):
    """A device of 1 GiB (stages/memory.py's device_bytes, set here): 10,000 tiny worlds need
    at least 10,000 x (16 x 32 x 32 Q values + 128 x 96 depth pixels) x 4 bytes = 1.07 GiB, and
    a replay of as many items 10,000 x 10 x 32 x 32 bytes = 0.10 GiB."""
    from vags_jax.stages import memory

    monkeypatch.setattr(memory, "device_bytes", lambda: 2**30)
    out = _fresh_out(tmp_path)
    code, line = _cli(train.main, ["--out", out, "--set", "stage1.n_worlds=10000", "replay.capacity=10000"], capsys)
    assert code == 2 and re.search(r"stage1: 10,000 worlds need at least 1\.2 GiB of device memory .* more than "
                                   r"the 1\.0 GiB of cpu; lower stage1\.n_worlds .* --no-memory-check", line), line
    assert not os.path.exists(out)


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only directories")
def test_resuming_a_read_only_run_is_refused(tmp_path, capsys, fake_run):
    run = fake_run(tmp_path)
    modes = {}
    for root, dirs, _ in os.walk(run):
        for d in [root] + [os.path.join(root, d) for d in dirs]:
            modes[d] = os.stat(d).st_mode
    try:
        for d in modes:
            os.chmod(d, 0o555)
        code, line = _cli(train.main, ["--out", run, "--resume", "--quiet"], capsys)
    finally:
        for d, m in modes.items():
            os.chmod(d, m)
    assert code == 2 and re.search(rf"--out '{run}': cannot write in '{run}', so the run is read-only; make it writable", line), line


def test_demo_out_naming_a_file_is_one_line(tmp_path):
    target = tmp_path / "pictures.png"
    target.write_bytes(b"")
    p = subprocess.run([sys.executable, os.path.join(ROOT, "scripts", "demo.py"), "--out", str(target)], cwd=ROOT,
                       capture_output=True, text=True, timeout=60,
                       env={**os.environ, "PYTHONPATH": ROOT + os.pathsep + os.environ.get("PYTHONPATH", "")})
    assert p.returncode == 2
    assert _one_line(p.stderr) == f"demo.py: error: --out '{target}' is a file; give a folder for the pictures"


def test_train_needs_out(capsys):
    code, line = _cli(train.main, ["--config", "tiny"], capsys)
    assert code == 2 and "--out" in line


@pytest.mark.parametrize("kind,msg", [
    ("file", r"--out .* is a file, not a directory"),
    ("empty-name", r"--out must not be empty"),
    ("foreign-dir", r"is a non-empty directory that is not a run of train\.py \(it holds \['notes\.txt'\]\)"),
    ("run", r"already holds a run \(checkpoint 4\); pass --resume"),
])
def test_train_refuses_an_out_it_would_damage(kind, msg, tmp_path, capsys, fake_run):
    out = str(tmp_path / "out")
    if kind == "file":
        open(out, "w").close()
    elif kind == "empty-name":
        out = ""
    elif kind == "foreign-dir":
        os.makedirs(out)
        open(os.path.join(out, "notes.txt"), "w").close()
    else:
        out = fake_run(tmp_path)
    before = _snapshot(out) if os.path.isdir(out) else None
    code, line = _cli(train.main, ["--config", "tiny", "--out", out], capsys)
    assert code == 2 and re.search(msg, line), line
    if before is not None:
        assert _snapshot(out) == before


def _snapshot(path):
    """{relative file path: bytes} of a directory tree."""
    out = {}
    for root, _, files in os.walk(path):
        for f in files:
            p = os.path.join(root, f)
            with open(p, "rb") as fh:
                out[os.path.relpath(p, path)] = fh.read()
    return out


@pytest.mark.parametrize("init,msg", [
    ("{tmp}/none.pth", r"net\.init '.*none\.pth': no such file; give a torchvision DenseNet-121 state dict you have"),
    ("{tmp}/w.txt", r"net\.init must be a torchvision DenseNet-121 state dict file \(\.pth / \.pt, or \.npz"),
])
def test_train_checks_net_init_first(init, msg, tmp_path, capsys):
    argv = ["--config", "tiny", "--out", str(tmp_path / "o"), "--set", "net.trunk=densenet121",
            "net.init=" + init.format(tmp=tmp_path)]
    code, line = _cli(train.main, argv, capsys)
    assert code == 2 and line.startswith("train.py: error: ") and re.search(msg, line), line
    assert not os.path.exists(tmp_path / "o")


def test_a_failed_start_leaves_an_out_that_the_corrected_command_accepts(tmp_path, capsys):
    """A run that stopped before its first checkpoint left config.json and metrics.jsonl (and an
    empty checkpoints/): the fresh-run checks accept that directory again."""
    out = str(tmp_path / "out")
    checkpoint.save_config(out, C.tiny())
    open(os.path.join(out, "metrics.jsonl"), "w").close()
    os.makedirs(os.path.join(out, "checkpoints"))
    requests.check_fresh_out(out)  # no error
    args = train.parse_args(["--config", "tiny", "--out", out, "--set", "stage1.iterations=3"])
    assert requests.prepare_stage1(args).cfg.stage1.iterations == 3
    # ... but resuming it says why not.
    code, line = _cli(train.main, ["--out", out, "--resume"], capsys)
    assert code == 2 and "has no checkpoint yet" in line and "without --resume" in line


# ----------------------------------------------------------------------------- run directories

def _state_like(cfg, iteration):
    """Arrays in the layout of a Stage1State of ``cfg`` (the parts a config fixes, and a stub
    env), random so that every array has data files, placed on the device without compiling
    anything and written with the real checkpoint.save."""
    rng = np.random.default_rng(iteration)

    def fill(s):
        if np.issubdtype(s.dtype, np.floating):
            return rng.normal(size=s.shape).astype(s.dtype)
        if s.dtype == np.bool_:
            return rng.random(s.shape) < 0.5
        return rng.integers(0, 100, size=s.shape).astype(s.dtype)

    state = jax.tree.map(fill, stages.checkpoint_layout(cfg))
    state["iteration"] = np.asarray(iteration, np.int32)
    state["env"] = {"height": rng.normal(size=(cfg.stage1.n_worlds, 4)).astype(np.float32)}
    return jax.device_put(state)


@pytest.fixture(scope="module")
def run_template(tmp_path_factory):
    """A run directory: config.json (the tests' tiny config, 8 iterations), checkpoints 2 and 4."""
    cfg = C.replace(C.tiny(), **TINY_TEST_OVERRIDES, **{"stage1.iterations": 8})
    run = str(tmp_path_factory.mktemp("template") / "run")
    checkpoint.save_config(run, cfg)
    for step in (2, 4):
        checkpoint.save(run, step, _state_like(cfg, step))
    with open(os.path.join(run, "metrics.jsonl"), "w") as f:
        for i in range(4):
            f.write(json.dumps({"iteration": i, "loss": 0.1}) + "\n")
    return run


@pytest.fixture
def fake_run(run_template):
    def make(tmp_path, name="run"):
        dst = str(tmp_path / name)
        shutil.copytree(run_template, dst)
        return dst

    return make


def _step_files(run, step, pattern):
    import glob

    return glob.glob(os.path.join(run, "checkpoints", str(step), pattern))


def _largest_file(run, step):
    files = [os.path.join(r, f) for r, _, fs in os.walk(os.path.join(run, "checkpoints", str(step))) for f in fs]
    return max(files, key=os.path.getsize)


def _truncate(paths):
    assert paths
    for p in paths:
        with open(p, "r+b") as f:
            f.truncate(os.path.getsize(p) // 2)


def _write(path, data: bytes):
    with open(path, "wb") as f:
        f.write(data)


def _damage(run, kind):
    cfg_path = os.path.join(run, "config.json")
    if kind == "config-missing":
        os.remove(cfg_path)
    elif kind == "config-garbled":
        _write(cfg_path, b'{"seed": 0, "scene": {')
    elif kind == "config-empty":
        _write(cfg_path, b"")
    elif kind == "config-binary":
        _write(cfg_path, b"\xff\xfe\x00garbage")
    elif kind == "config-list":
        _write(cfg_path, b"[1, 2]")
    elif kind == "config-unknown-field":
        data = json.load(open(cfg_path))
        data["dqn"]["gama"] = 0.3
        _write(cfg_path, json.dumps(data).encode())
    elif kind == "config-bad-value":
        data = json.load(open(cfg_path))
        data["stage1"]["n_worlds"] = "two"
        _write(cfg_path, json.dumps(data).encode())
    elif kind == "no-checkpoints":
        shutil.rmtree(os.path.join(run, "checkpoints"))
        os.makedirs(os.path.join(run, "checkpoints"))
    elif kind == "data-truncated":  # the largest file: the replay buffer's data
        _truncate([_largest_file(run, 4)])
    elif kind == "data-emptied":
        _write(_largest_file(run, 4), b"")
    elif kind == "data-deleted":
        os.remove(_largest_file(run, 4))
    elif kind == "all-data-truncated":
        _truncate(_step_files(run, 4, "default/ocdbt.process_0/d/*"))
    elif kind == "all-data-emptied":
        for p in _step_files(run, 4, "default/ocdbt.process_0/d/*"):
            _write(p, b"")
    elif kind == "index-truncated":
        _truncate(_step_files(run, 4, "default/d/*"))
    elif kind == "metadata-truncated":
        _truncate(_step_files(run, 4, "default/_METADATA"))
    elif kind == "metadata-missing":
        os.remove(_step_files(run, 4, "default/_METADATA")[0])
    elif kind == "manifest-garbled":
        _write(_step_files(run, 4, "default/manifest.ocdbt")[0], b"\x00garbage" * 8)
    elif kind == "checkpoint-metadata-garbled":
        _write(_step_files(run, 4, "_CHECKPOINT_METADATA")[0], b"{not json")
    elif kind == "sharding-garbled":
        _write(_step_files(run, 4, "default/_sharding")[0], b"{not json")
    elif kind == "foreign-network":  # config.json of another network than the checkpoint's
        data = json.load(open(cfg_path))
        data["net"]["small_width"] = 16
        _write(cfg_path, json.dumps(data).encode())
    elif kind == "foreign-heightmap":
        data = json.load(open(cfg_path))
        data["workspace"]["heightmap_px"] = 40
        _write(cfg_path, json.dumps(data).encode())
    elif kind == "foreign-replay":
        data = json.load(open(cfg_path))
        data["replay"]["capacity"] = 128
        _write(cfg_path, json.dumps(data).encode())
    elif kind == "wrong-iteration":
        cfg = checkpoint.load_config(run)
        shutil.rmtree(_step_files(run, 4, "")[0])
        checkpoint.save(run, 4, _state_like(cfg, 3))
    elif kind == "missing-part":
        cfg = checkpoint.load_config(run)
        shutil.rmtree(_step_files(run, 4, "")[0])
        state = _state_like(cfg, 4)
        del state["replay"]
        checkpoint.save(run, 4, state)
    elif kind == "metrics-garbled":
        with open(os.path.join(run, "metrics.jsonl"), "a") as f:
            f.write('{"iteration": 4, "lo\n')
    else:
        raise AssertionError(kind)


DAMAGE = {  # kind: what the one-line error must say
    "config-missing": r"no config\.json in .*: is this a run directory written by train\.py",
    "config-garbled": r"config\.json is damaged \(.*\): it is not the JSON train\.py writes",
    "config-empty": r"config\.json is damaged",
    "config-binary": r"config\.json is damaged",
    "config-list": r"config\.json is not a valid config \(expected a mapping",
    "config-unknown-field": r"config\.json is not a valid config \(unknown config field\(s\) \['gama'\]",
    "config-bad-value": r"config\.json is not a valid config \(Stage\.n_worlds must be an int, got 'two'",
    "all-data-truncated": r"checkpoint 4 in .* is damaged or incomplete.*delete .*checkpoints/4 to go back to checkpoint 2",
    "all-data-emptied": r"checkpoint 4 in .* is damaged or incomplete",
    "index-truncated": r"checkpoint 4 in .* is damaged or incomplete, its files cannot be read \(.*/checkpoints/4/default/d/\w+: Requested byte range",
    "metadata-truncated": r"checkpoint 4 .* damaged .*_METADATA is not valid JSON",
    "metadata-missing": r"checkpoint 4 .* damaged .*_METADATA is missing",
    "manifest-garbled": r"checkpoint 4 .* damaged .*manifest\.ocdbt",
    "checkpoint-metadata-garbled": r"checkpoint 4 .* damaged .*_CHECKPOINT_METADATA is not valid JSON",
    "sharding-garbled": r"checkpoint 4 .* damaged .*_sharding is not valid JSON",
    "foreign-network": r"checkpoint 4 in .* does not fit this run's state: it was written with a different config",
}
TRAIN_ONLY = {  # eval.py reads only the learner, which these leave intact (or may: the largest
    # data file often holds only replay-buffer arrays, and then the learner is rightly read)
    "data-truncated": r"checkpoint 4 in .* is damaged or incomplete.*delete .*checkpoints/4 to go back to checkpoint 2",
    "data-emptied": r"checkpoint 4 in .* is damaged or incomplete",
    "data-deleted": r"checkpoint 4 in .* is damaged or incomplete",
    "no-checkpoints": r"has no checkpoint yet .* start it again without --resume",
    "foreign-replay": r"checkpoint 4 in .* does not fit this run's state.*\(replay leaf 00000: saved \(64, ",
    # the small trunk is fully convolutional: only the replay buffer shows another heightmap size
    "foreign-heightmap": r"checkpoint 4 in .* does not fit this run's state.*\(replay leaf .*\(64, 40, 40, 3\)",
    "wrong-iteration": r"checkpoint 4 in .* holds iteration 3, not 4",
    "missing-part": r"checkpoint 4 in .* does not fit .*it has no part 'replay'",
    "metrics-garbled": r"metrics\.jsonl is damaged at line 5 .* delete that line",
}


@pytest.mark.parametrize("stage", [[], ["--stage", "gdnet"]], ids=["pipeline", "stage1"])
@pytest.mark.parametrize("kind", sorted({**DAMAGE, **TRAIN_ONLY}))
def test_train_resume_names_the_damage(kind, stage, tmp_path, capsys, fake_run):
    """The whole pipeline's --resume (which would train GG-CNN first in this run) and stage 1's
    both check stage 1's checkpoint before anything else."""
    run = fake_run(tmp_path)
    _damage(run, kind)
    before = _snapshot(run)
    code, line = _cli(train.main, ["--out", run, "--resume", "--quiet"] + stage, capsys)
    assert code == 2 and line.startswith("train.py: error: ")
    assert re.search({**DAMAGE, **TRAIN_ONLY}[kind], line), line
    assert _snapshot(run) == before, "a refused --resume must not touch the run"


@pytest.mark.parametrize("kind", sorted(DAMAGE))
def test_eval_run_names_the_damage(kind, tmp_path, capsys, fake_run):
    run = fake_run(tmp_path)
    _damage(run, kind)
    code, line = _cli(eval_cli.main, ["--run", run, "--groups", "1-2", "--rounds", "2"], capsys)
    assert code == 2 and line.startswith("eval.py: error: ")
    assert re.search(DAMAGE[kind], line), line


def test_eval_gdnet_alone_cannot_plan_by_the_success_net(tmp_path, capsys, fake_run):
    run = fake_run(tmp_path)
    argv = ["--run", run, "--policy", "gdnet", "--groups", "1-2", "--rounds", "2", "--set", "vags.direct_score=success"]
    code, line = _cli(eval_cli.main, argv, capsys)
    assert code == 2 and "--policy gdnet plans with GDNet alone: vags.direct_score must be one of q, q_mean" in line


@pytest.mark.parametrize("policy", ["ggcnn", "ggcnn-close"])
def test_eval_ggcnn_on_a_run_without_ggcnn_says_how_to_train_one(policy, tmp_path, capsys, fake_run):
    run = fake_run(tmp_path)
    code, line = _cli(eval_cli.main, ["--run", run, "--policy", policy], capsys)
    assert code == 2 and line.startswith("eval.py: error: ")
    assert f"has no GG-CNN checkpoint ({run}/ggcnn): train one with python train.py --stage ggcnn --out {run}" in line


def test_eval_gdnet_on_a_ggcnn_only_run_says_what_it_holds(tmp_path, capsys):
    run = str(tmp_path / "gg")
    checkpoint.save_config(os.path.join(run, "ggcnn"), C.tiny())
    code, line = _cli(eval_cli.main, ["--run", run], capsys)
    assert code == 2 and f"run {run} holds only a GG-CNN" in line and "--policy ggcnn" in line


def test_eval_heuristic_on_a_run_reads_only_its_config(tmp_path, capsys, fake_run):
    run = fake_run(tmp_path)
    _damage(run, "config-garbled")
    code, line = _cli(eval_cli.main, ["--run", run, "--policy", "heuristic"], capsys)
    assert code == 2 and "config.json is damaged" in line


@pytest.mark.parametrize("argv,code,msg", [
    (["--set", "stage1.iterations=2"], 2,
     r"already at iteration 4: the requested stage1\.iterations=2 are already done.*config\.json unchanged"),
    (["--set", "stage1.iterations=4"], 0, r"already at iteration 4 of 4: nothing to train \(config\.json unchanged\)"),
    (["--set", "dqn.gamma=0.3"], 2, r"with --resume only stage1\.iterations may change.*\['dqn\.gamma'\]"),
    (["--set", "stage1.iterations=2.5"], 2, r"stage1\.iterations must be an int"),
    (["--config", "tiny"], 2, r"--resume takes the run's own config\.json; drop --config"),
])
def test_resume_never_rewrites_the_config_silently(argv, code, msg, tmp_path, capsys, fake_run):
    run = fake_run(tmp_path)
    before = _snapshot(run)
    got, line = _cli(train.main, ["--out", run, "--resume", "--stage", "gdnet", "--quiet"] + argv, capsys)
    assert got == code and re.search(msg, line), line
    assert _snapshot(run) == before


def test_resume_raising_iterations_passes_the_checks(tmp_path, fake_run):
    """The only allowed change: more iterations, recorded as where it came from."""
    run = fake_run(tmp_path)
    plan = requests.prepare_stage1(train.parse_args(["--out", run, "--resume", "--set", "stage1.iterations=12"]))
    assert plan.step == 4 and plan.cfg.stage1.iterations == 12 and plan.raised_from == 8 and not plan.done
    assert set(plan.arrays) == {"env", "learner", "replay", "key", "iteration", "attempts"}


@pytest.mark.parametrize("kind", ["foreign-network", "old-calibration"])
def test_resume_checks_a_stage2_checkpoint_before_anything_runs(kind, tmp_path, capsys, fake_run, no_compiling):
    """A run whose stage 1 is done and whose stage 2 stopped at iteration 1: --resume reads stage
    2's checkpoint metadata up front and refuses one of another network (or a calibration of 2
    entries, from before the mean success after a move was kept), in one line, run untouched."""
    from vags_jax.stages import rundir

    run = fake_run(tmp_path)
    cfg = C.replace(checkpoint.load_config(run), **{"stage1.iterations": 4})
    checkpoint.save_config(run, cfg)
    other = C.replace(cfg, **{"net.small_width": cfg.net.small_width * 2}) if kind == "foreign-network" else cfg
    gd = rundir.learner_target(other, "gdnet")
    d = rundir.stage_dir(run, "stage2")
    checkpoint.save(d, 1, {"gdnet": gd, "vanet": rundir.learner_target(other, "vanet"), "success": gd,
                           "calibration": np.zeros((3 if kind == "foreign-network" else 2,), np.float32)})
    with open(os.path.join(d, "metrics.jsonl"), "w") as f:
        f.write(json.dumps({"iteration": 0, "loss_vanet": 0.1}) + "\n")
    before = _snapshot(run)
    code, line = _cli(train.main, ["--out", run, "--resume", "--quiet"], capsys)
    assert code == 2 and line.startswith("train.py: error: checkpoint 1 in ")
    assert re.search(r"stage2 does not fit this run's state: it was written with a different config", line), line
    assert ("calibration" in line) == (kind == "old-calibration"), line
    assert _snapshot(run) == before, "a refused --resume must not touch the run"


def test_vpg_resume_checks_its_checkpoint_before_anything_runs(tmp_path, capsys, no_compiling):
    """train.py --stage vpg --resume on a VPG checkpoint of another network: one line, run untouched."""
    from vags_jax.stages import vpg as vpg_stage

    run = str(tmp_path / "run")
    d = vpg_stage.vpg_dir(run)
    cfg = C.replace(C.tiny(), **TINY_TEST_OVERRIDES)
    checkpoint.save_config(d, cfg)
    other = C.replace(cfg, **{"net.small_width": cfg.net.small_width * 2})
    checkpoint.save(d, 1, {"learner": vpg_stage.learner_target(other)})
    with open(os.path.join(d, "metrics.jsonl"), "w") as f:
        f.write(json.dumps({"iteration": 0, "loss": 0.1}) + "\n")
    before = _snapshot(run)
    code, line = _cli(train.main, ["--stage", "vpg", "--out", run, "--resume", "--quiet"], capsys)
    assert code == 2 and re.search(r"checkpoint 1 in .*vpg does not fit this run's state", line), line
    assert _snapshot(run) == before


def test_a_chunk_out_of_accelerator_memory_is_one_line_with_what_to_lower(tmp_path, capsys, failed_runtime_token):
    """XLA's RESOURCE_EXHAUSTED in a chunk (VPG's first H100 run asked for 48.44 GiB) ends the
    stage with one line: what XLA tried, the settings to lower, what was kept; timings.jsonl says
    out_of_memory; JAX's exit handler no longer re-raises the failed program's runtime token."""
    from types import SimpleNamespace

    class Stage:
        def run(self, state, n):
            raise jax.errors.JaxRuntimeError("RESOURCE_EXHAUSTED: Out of memory while trying to allocate 48.44GiB "
                                             "with allocator GPU_0_bfc on device 0.\nmore lines")

    out = str(tmp_path)
    args = SimpleNamespace(chunk=2, checkpoint_every=1, quiet=True, out=out, max_minutes=None)
    state = SimpleNamespace(attempts=np.int32(0))
    _, it, status, _, _ = driver.run_chunks("vpg", Stage(), state, 0, 4, out, args, None)
    assert it == 0 and status.startswith("out of accelerator memory in vpg (Out of memory while trying to "
                                         "allocate 48.44GiB")
    assert "lower vpg.n_worlds, net.forward_batch or camera.render_batch" in status and "nothing was saved" in status
    assert driver.end_of_segment(args, "vpg", 0, it, 0.0, status)
    err = capsys.readouterr().err  # the compile notice, then the error
    assert "Traceback" not in err
    assert err.strip().splitlines()[-1].startswith("train.py: error: out of accelerator memory in vpg")
    with open(os.path.join(out, "timings.jsonl")) as f:
        assert json.loads(f.readlines()[-1])["status"] == "out_of_memory"
    failed_runtime_token.wait_for_tokens()  # JAX's atexit handler: raised after the one line before


# ----------------------------------------------------------------------------- eval.py flags

EVAL_FLAG_CASES = [
    (["--rounds", "0"], r"argument --rounds: must be an int >= 1"),
    (["--rounds", "-1"], r"argument --rounds: must be an int >= 1"),
    (["--rounds", "many"], r"argument --rounds: must be an int, got 'many'"),
    (["--rounds", "10000000"], r"argument --rounds: must be an int >= 1 and <= 1,048,576"),
    (["--seed", "-1"], r"argument --seed: must be an int >= 0"),
    (["--seed", "x"], r"argument --seed: must be an int"),
    (["--step", "-1"], r"argument --step: must be an int >= 0"),
    (["--speed", "0"], r"argument --speed: must be a finite number > 0"),
    (["--speed", "nan"], r"argument --speed: must be a finite number > 0"),
    (["--speed", "-2"], r"argument --speed: must be a finite number > 0"),
    (["--speed", "1000"], r"argument --speed: must be a finite number > 0 and <= 100"),
    (["--groups", ""], r"--groups '': expected object counts"),
    (["--groups", "3-1"], r"--groups '3-1': expected object counts"),
    (["--groups", "a"], r"--groups 'a': expected object counts"),
    (["--groups", "1-100000000"], r"--groups '1-100000000': expected object counts"),
    (["--groups", "0"], r"group sizes \[0\] are outside 1\.\.3"),
    (["--groups", "1-10"], r"outside 1\.\.3: the scene holds at most scene\.max_objects = 3"),
    (["--policy", "vpgx"], r"unknown policy 'vpgx'"),
    (["--policy", "vpg"], r"policy vpg needs --run"),
    (["--policy", "gdnet"], r"policy gdnet needs --run"),
    (["--policy", "ggcnn"], r"policy ggcnn needs --run"),
    (["--policy", "ggcnn-close"], r"policy ggcnn-close needs --run"),
    (["--set", "benchmark.rounds=0"], r"benchmark\.rounds must be"),
    (["--set", "benchmark.groups=[1, 11]"], r"benchmark\.groups .* go above scene\.max_objects \(3\)"),
    (["--speed", "1", "--set", "benchmark.speed=2"], r"give the speed once"),
    (["--step", "3"], r"--step selects a gdnet, vags or vpg checkpoint; policy 'heuristic' uses none"),
    (["--networks", "stage2"], r"--networks selects a stage's VAGS networks; policy 'heuristic' uses none"),
    (["--networks", "stage4"], r"argument --networks: invalid choice: 'stage4'"),
    (["--policy", "vags"], r"policy vags needs --run"),
    (["--no-viewpoint"], r"--no-viewpoint is for --policy vags, not heuristic"),
    (["--threshold-sweep", "1.7:1.8:0.01"], r"--threshold-sweep is for --policy vags, not heuristic"),
    (["--record", "pics"], r"--record is for --policy vags, not heuristic"),
    (["--compare", "a.json"], r"--compare a\.json: not a report written by eval\.py"),
    (["--compare", "nope"], r"--compare 'nope': not a policy \(vags, .*mvp"),
    (["--compare", "random", "mvp"], r"--compare mvp: policy mvp needs --run"),
    (["--compare", "no_such_run:vags"], r"--compare no_such_run:vags: run directory 'no_such_run' does not exist"),
    (["--compare", "random", "--seeds", "1,2"], r"--compare plays one table of several methods; drop --seeds"),
    (["--policy", "mvp"], r"policy mvp needs --run"),
    (["--set", "dqn.gamma=2"], r"dqn\.gamma must be in \[0, 1\)"),
    (["--set", "scene.max_objects=true"], r"scene\.max_objects must be an int, got True"),
    (["--set", 'scene.shapes=["cube", "cuboid_long", "blob"]'], r"unknown shape 'blob'"),
    (["--config", "nope"], r"unknown config preset 'nope'"),
    (["--run", ""], r"--run must not be empty"),
    (["--config", ""], r"unknown config preset ''; choose one of"),
    (["--set", "camera.renderer=warp"], r"camera\.renderer=warp needs (an NVIDIA GPU, but JAX runs on cpu|warp-lang)"),
    (["--policy", "random", "--plot", "fig.svg"], r"--plot 'fig\.svg': the plot is a PNG image"),
    (["--unknown"], r"unrecognized arguments: --unknown"),
]


@pytest.mark.parametrize("argv,msg", EVAL_FLAG_CASES, ids=[" ".join(c[0]) for c in EVAL_FLAG_CASES])
def test_eval_flag_is_refused(argv, msg, capsys):
    code, line = _cli(eval_cli.main, ["--groups", "1-2", "--rounds", "2"] + argv
                      if not any(a in argv for a in ("--groups", "--rounds")) else argv, capsys)
    assert code == 2 and line.startswith("eval.py: error: ")
    assert re.search(msg, line), line


def test_eval_rounds_that_cannot_fit(capsys):
    code, line = _cli(eval_cli.main, ["--config", "default", "--groups", "1", "--rounds", "1000000"], capsys)
    assert code == 2 and "--rounds 1,000,000 x 1 groups = 1,000,000 worlds (every group plays in one batch) need Q maps of 16 x 224 x 224" in line


@pytest.mark.parametrize("kind,msg", [
    ("out-dir", r"--out .* is a directory; give a file name"),
    ("out-under-file", r"--out .* is a file, not a directory"),
    ("run-is-file", r"--run .* is a file; give the run directory train\.py wrote"),
    ("run-and-config", r"--run uses the run's own config\.json; drop --config"),
    ("gdnet-net-change", r"--set must not change net\.\* \(but net\.n_rotations .*\) or workspace\.\*"),
    ("gdnet-missing-step", r"no checkpoint 3 in .* \(available steps: \[2, 4\]\)"),
])
def test_eval_paths(kind, msg, tmp_path, capsys, fake_run):
    base = ["--groups", "1-2", "--rounds", "2"]
    if kind == "out-dir":
        argv = base + ["--policy", "random", "--out", str(tmp_path)]
    elif kind == "out-under-file":
        open(tmp_path / "f", "w").close()
        argv = base + ["--policy", "random", "--out", str(tmp_path / "f" / "r.json")]
    elif kind == "run-is-file":
        open(tmp_path / "f", "w").close()
        argv = base + ["--run", str(tmp_path / "f")]
    elif kind == "run-and-config":
        argv = base + ["--run", fake_run(tmp_path), "--config", "tiny"]
    elif kind == "gdnet-net-change":
        argv = base + ["--run", fake_run(tmp_path), "--set", "net.small_width=16"]
    else:
        argv = base + ["--run", fake_run(tmp_path), "--step", "3"]
    code, line = _cli(eval_cli.main, argv, capsys)
    assert code == 2 and re.search(msg, line), line


# ----------------------------------------------------------------------------- real frames

def _down_pose(x, y, z):
    """Camera-to-world pose of a camera at (x, y, z) looking straight down (as
    camera.straight_down_pose, in NumPy: nothing to compile)."""
    return np.array([[1.0, 0, 0, x], [0, -1, 0, y], [0, 0, -1, z], [0, 0, 0, 1]])


def _look_at_pose(position=(0.0, -0.25, 0.6), target=(0.0, 0.0, 0.0)):
    """As camera.look_at with up = +z, in NumPy."""
    position, target = np.asarray(position, float), np.asarray(target, float)
    z = (target - position) / np.linalg.norm(target - position)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    pose = np.eye(4)
    pose[:3, :3] = np.stack([x, np.cross(z, x), z], axis=1)
    pose[:3, 3] = position
    return pose


def _rays(cam):
    cx, cy = cam.principal_point
    u, v = np.meshgrid((np.arange(cam.width) - cx) / cam.fx, (np.arange(cam.height) - cy) / cam.fy)
    return np.stack([u, v, np.ones_like(u)], axis=-1)


def _table_frame(cam, pose, table_z=0.0):
    """Depth (h, w) of the plane z = table_z seen from ``pose`` (metres, 0 where not hit)."""
    rays = _rays(cam)  # (h, w, 3) camera frame, z = 1
    d = rays @ pose[:3, :3].T  # world directions
    s = (table_z - pose[2, 3]) / np.where(d[..., 2] < 0, d[..., 2], -np.inf)
    return np.where(s > 0, s, 0.0).astype(np.float32)


FRAME_CAM = C.Camera(width=32, height=24, fx=30.9, fy=30.9)
FRAME_WS = Workspace(heightmap_px=16)


def _frame():
    pose = _down_pose(0.0, 0.0, 0.5)
    depth = np.full((FRAME_CAM.height, FRAME_CAM.width), 0.45, np.float32)
    rgb = np.full((FRAME_CAM.height, FRAME_CAM.width, 3), 128, np.uint8)
    return depth, rgb, pose


FRAME_ERRORS = {
    "depth-shape": (lambda d, r, p: (d[:-1], r, p), r"depth has shape \(23, 32\) but the camera config expects"),
    "depth-4d": (lambda d, r, p: (d[None, None], r, p), r"2-D"),
    "depth-uint16-mm": (lambda d, r, p: ((d * 1000).astype(np.uint16), r, p), r"uint16 .*millimetres"),
    "depth-bool": (lambda d, r, p: (d > 0, r, p), r"floating point metres"),
    "depth-mm-float": (lambda d, r, p: (d * 1000, r, p), r"millimetres; divide by 1000"),
    "depth-negative": (lambda d, r, p: (-d, r, p), r"negative"),
    "rgb-2-channels": (lambda d, r, p: (d, r[..., :2], p), r"rgb must have shape"),
    "rgb-float": (lambda d, r, p: (d, r.astype(np.float32) / 255, p), r"uint8"),
    "rgb-transposed": (lambda d, r, p: (d, r.transpose(1, 0, 2), p), r"rgb must have shape \(24, 32, 3\)"),
    "pose-3x4": (lambda d, r, p: (d, r, p[:3]), r"cam_pose must be a \(4, 4\) camera-to-world transform, got shape \(3, 4\)"),
    "pose-nan": (lambda d, r, p: (d, r, np.where(np.eye(4) > 0, np.nan, p)),
                 r"cam_pose must be finite, but it holds NaN or inf at \[0, 0\] = nan, \[1, 1\] = nan, \[2, 2\] = nan, "
                 r"\[3, 3\] = nan$"),
    "pose-strings": (lambda d, r, p: (d, r, p.astype(str)), r"cam_pose must be a numeric"),
    "pose-mirrored": (lambda d, r, p: (d, r, p * np.array([1, 1, -1, 1])), r"rigid"),
    "pose-scaled": (lambda d, r, p: (d, r, np.diag([2.0, 2, 2, 1]) @ p), r"rigid"),
    "pose-millimetres": (lambda d, r, p: (d, r, _moved(p, p[:3, 3] * 1000)),
                         r"500 m from the robot origin.*millimetres; divide cam_pose\[:3, 3\] by 1000"),
    "pose-below-table": (lambda d, r, p: (d, r, _moved(p, [0.0, 0.0, -0.5])),
                         r"z = -0\.5 m, at or below the table top .* world-to-camera .* np\.linalg\.inv"),
    "pose-looking-up": (lambda d, r, p: (d, r, _flip_z(p)), r"optical axis .* does not point down"),
    "pose-opengl": (lambda d, r, p: (d, r, p @ np.diag([1.0, -1, -1, 1])), r"OpenGL convention"),
}


def _moved(p, t):
    q = np.array(p, np.float64)
    q[:3, 3] = t
    return q


def _flip_z(p):
    """The same camera position, looking up (rotated 180 degrees about its x axis)."""
    return p @ np.diag([1.0, -1, -1, 1])


@pytest.mark.parametrize("kind", sorted(FRAME_ERRORS))
def test_real_frame_error(kind):
    change, msg = FRAME_ERRORS[kind]
    depth, rgb, pose = change(*_frame())
    with pytest.raises(ValueError, match=msg):
        heightmap.heightmap_from_frame(depth, rgb, pose, FRAME_CAM, FRAME_WS)


def _sparse(d, r, p):
    d = np.zeros_like(d)
    d[0, :3] = 0.45  # 3 of 768 pixels
    return d, r, p


def _elsewhere(d, r, p):
    p = p.copy()
    p[:2, 3] = (2.0, 2.0)  # looking at the floor 2 m away from the workspace
    return d, r, p


def _world_to_camera(d, r, p):
    pose = _look_at_pose()
    return _table_frame(FRAME_CAM, pose), r, np.linalg.inv(pose)  # the extrinsics, not the pose


def _table_lower(d, r, p):
    pose = _look_at_pose()
    return _table_frame(FRAME_CAM, pose, table_z=-0.3), r, pose  # the table is not where ws says


FRAME_WARNINGS = {
    "no-valid-depth": (lambda d, r, p: (np.full_like(d, np.nan), r, p), r"only 0 % of the depth pixels are valid"),
    "too-little-depth": (_sparse, r"only 0\.39 % of the depth pixels are valid"),
    "nothing-in-workspace": (_elsewhere, r"none of the 768 valid depth points falls inside the workspace"),
    "world-to-camera": (_world_to_camera, r"below the table top .*world-to-camera given instead of camera-to-world"),
    "wrong-table-z": (_table_lower, r"100 % of the depth points inside the workspace lie more than 2 cm below"),
}


@pytest.mark.parametrize("kind", sorted(FRAME_WARNINGS))
def test_real_frame_warning(kind):
    """Valid but useless frames warn (FrameWarning) before anything is compiled; as errors
    here, so the call stops at the warning."""
    change, msg = FRAME_WARNINGS[kind]
    depth, rgb, pose = change(*_frame())
    with warnings.catch_warnings():
        warnings.simplefilter("error", heightmap.FrameWarning)
        with pytest.raises(heightmap.FrameWarning, match=msg):
            heightmap.heightmap_from_frame(depth, rgb, pose, FRAME_CAM, FRAME_WS)


def test_numpy_poses_match_the_camera_module():
    assert np.allclose(_down_pose(0.1, 0.2, 0.5), camera.straight_down_pose(np.array([0.1, 0.2, 0.5])), atol=1e-6)
    assert np.allclose(_look_at_pose(FRAME_CAM.global_position, FRAME_CAM.global_target),
                       camera.global_pose(FRAME_CAM), atol=1e-6)
    assert np.allclose(_rays(FRAME_CAM), camera.pixel_rays(FRAME_CAM), atol=1e-5)


def test_a_good_look_at_frame_passes_the_checks():
    """The checks accept a correct oblique view of the table (no warning, no error)."""
    pose = _look_at_pose()
    depth = _table_frame(FRAME_CAM, pose)
    with warnings.catch_warnings():
        warnings.simplefilter("error", heightmap.FrameWarning)
        heightmap.check_frame_pose(pose, FRAME_WS)
        heightmap.check_frame_points(depth, pose, FRAME_CAM, FRAME_WS)


# ----------------------------------------------------------------------------- divergence

def _metrics(**bad):
    m = {k: np.array([0.5, 0.4, 0.3], np.float32) for k in stages.METRICS}
    for k, (i, v) in bad.items():
        m[k][i] = v
    return m


@pytest.mark.parametrize("bad,msg", [
    ({"loss": (1, np.nan)}, r"loss became non-finite at iteration 11 \(loss = nan\)"),
    ({"q_max": (0, np.inf)}, r"q_max became non-finite at iteration 10"),
    ({"td_abs": (2, -np.inf), "q_executed": (2, np.nan)}, r"td_abs and q_executed became non-finite at iteration 12"),
])
def test_non_finite_training_metrics_are_caught(bad, msg):
    got = driver.nonfinite(_metrics(**bad), 10)
    assert got is not None and re.search(msg, got) and "lower dqn.learning_rate" in got
    assert driver.nonfinite(_metrics(), 10) is None


# ----------------------------------------------------------------------------- real processes

@pytest.mark.parametrize("script,argv,msg", [
    ("train.py", ["--out", "{tmp}/o", "--chunk", "-5"], "argument --chunk: must be an int >= 1"),
    ("train.py", ["--out", "{tmp}/o", "--set", "exploration.daes=maybe"], "exploration.daes must be true or false"),
    ("train.py", ["--out", "{run}", "--resume"], "is damaged or incomplete"),
    ("eval.py", ["--config", "tiny", "--rounds", "0"], "argument --rounds: must be an int >= 1"),
    ("eval.py", ["--run", "{run}", "--groups", "1-2", "--rounds", "2"], "is damaged or incomplete"),
], ids=["train-chunk", "train-set", "train-damaged", "eval-rounds", "eval-damaged"])
def test_command_line_exit_code_2_one_line(script, argv, msg, tmp_path, fake_run):
    run = fake_run(tmp_path, "damaged")
    _damage(run, "all-data-truncated")
    argv = [a.format(tmp=tmp_path, run=run) for a in argv]
    p = subprocess.run([sys.executable, os.path.join(ROOT, script)] + argv, cwd=ROOT,
                       capture_output=True, text=True, timeout=60,
                       env={**os.environ, "PYTHONPATH": ROOT + os.pathsep + os.environ.get("PYTHONPATH", "")})
    assert p.returncode == 2, p.stderr
    line = _one_line(p.stderr)
    assert line.startswith(f"{script}: error: ") and msg in line
    assert not os.path.exists(tmp_path / "o")


def test_train_reads_its_flags_before_importing_the_physics():
    # A mistyped flag or --help answers without importing MuJoCo, MJX and the stages (about 4 s).
    code = ("import sys, train; train.parse_args(['--out', 'x']); "
            "print('mujoco' in sys.modules, 'vags_jax.stages.driver' in sys.modules)")
    p = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=60,
                       env={**os.environ, "PYTHONPATH": ROOT + os.pathsep + os.environ.get("PYTHONPATH", "")})
    assert p.returncode == 0, p.stderr
    assert p.stdout.split() == ["False", "False"]


# ----------------------------------------------------------------------------- stages 2, 3 and VAGS evaluation

@pytest.mark.parametrize("argv,msg", [
    (["--stage", "stage2"], r"stage2 starts from the end of stage 1: GDNet, and .* reached iteration 4 of 8 "
                            r"there: run python train\.py --out .* --resume \(every stage in order\) "
                            r"or --stage stage1 first"),
    (["--stage", "alternate"], r"stage3 starts from the end of stage 1"),
    (["--stage", "stage3", "--set", "dqn.gamma=0.3"], r"with --stage stage3 only stage3\.iterations may change"),
    (["--stage", "vanet", "--config", "tiny"], r"--stage stage2 takes the run's own config\.json; drop --config"),
    (["--stage", "stage9"], r"argument --stage: invalid choice: 'stage9'"),
])
def test_a_later_stage_needs_the_earlier_ones(argv, msg, tmp_path, capsys, fake_run):
    run = fake_run(tmp_path)
    before = _snapshot(run)
    code, line = _cli(train.main, ["--out", run, "--quiet"] + argv, capsys)
    assert code == 2 and re.search(msg, line), line
    assert _snapshot(run) == before


@pytest.mark.parametrize("setting", ["vags.local_planner", "vags.train_ggcnn"])
def test_a_later_stage_needs_ggcnn_only_when_the_run_uses_it(setting, tmp_path, capsys, fake_run):
    run = fake_run(tmp_path)
    value = "ggcnn" if setting == "vags.local_planner" else True
    checkpoint.save_config(run, C.replace(checkpoint.load_config(run), **{setting: value}))
    before = _snapshot(run)
    code, line = _cli(train.main, ["--out", run, "--quiet", "--stage", "stage2"], capsys)
    assert code == 2 and re.search(r"stage2 starts from the end of GG-CNN on physics-labelled views, and .* has "
                                   r"no checkpoint there: .* or --stage ggcnn first", line), line
    assert _snapshot(run) == before


def test_stage2_of_a_missing_run(tmp_path, capsys):
    code, line = _cli(train.main, ["--out", str(tmp_path / "none"), "--stage", "stage2"], capsys)
    assert code == 2 and "does not exist; train the stages before stage2 first" in line


def test_eval_vags_on_a_stage1_run_says_how_to_train_it(tmp_path, capsys, fake_run):
    run = fake_run(tmp_path)
    code, line = _cli(eval_cli.main, ["--run", run, "--policy", "vags"], capsys)
    assert code == 2 and f"run {run} has no VANet yet" in line and f"python train.py --out {run} --resume" in line


@pytest.mark.parametrize("argv,msg", [
    (["--threshold-sweep", "1.8:1.7:0.01"], r"--threshold-sweep '1\.8:1\.7:0\.01': STEP must be > 0 and STOP >= START"),
    (["--threshold-sweep", "a:b:c"], r"--threshold-sweep 'a:b:c': expected START:STOP:STEP"),
    (["--threshold-sweep", "1.7:1.8"], r"expected START:STOP:STEP"),
    (["--threshold-sweep", "0:1:0"], r"STEP must be > 0"),
    (["--threshold-sweep", "0:1000:0.001"], r"gives 1,000,001 values; at most 1000"),
    (["--threshold-sweep", "0:1e308:1e-308"], r"'0:1e308:1e-308' gives more than 10\^308 values; at most 1000"),
    (["--threshold-sweep", "0:1:1e-320"], r"gives more than 10\^308 values"),
    (["--plot", "fig.jpg"], r"--plot 'fig\.jpg': the plot is a PNG image; give a path ending in \.png"),
    (["--plot", "/proc/vags_fig.png"], r"--plot '/proc/vags_fig\.png': (no permission to write|cannot write) in '/proc'"),
    (["--record", "/proc/vags_pictures"], r"--record '/proc/vags_pictures': (no permission to write|cannot write) in "
                                          r"'/proc'"),
    (["--threshold-sweep", "nan:1:0.1"], r"expected START:STOP:STEP"),
    (["--quantile-sweep", "0:2:0.5"], r"--quantile-sweep '0:2:0\.5': values must lie in \[0\.0, 1\.0\]"),
    (["--no-viewpoint", "--threshold", "1.7"], r"--no-viewpoint fixes the threshold at -inf"),
    (["--threshold", "inf"], r"--threshold must be a finite number"),
])
def test_eval_vags_flags_are_checked_first(argv, msg, tmp_path, capsys, fake_run):
    run = fake_run(tmp_path)
    code, line = _cli(eval_cli.main, ["--run", run, "--policy", "vags"] + argv, capsys)
    assert code == 2 and re.search(msg, line), line


# ----------------------------------------------------------------------------- predict (real frames from files)

def _predict_main(argv):
    from vags_jax import predict

    return predict.main(argv)


@pytest.fixture(scope="module")
def vags_run(tmp_path_factory):
    """A run with stage 3's networks (zeros: these tests stop before any network runs) and no
    GG-CNN, for the tiny config."""
    from vags_jax.stages import rundir

    cfg = C.tiny()
    run = str(tmp_path_factory.mktemp("predict") / "run")
    checkpoint.save_config(run, cfg)
    nets = {k: rundir.learner_target(cfg, "gdnet" if k != "vanet" else "vanet") for k in ("gdnet", "vanet", "success")}
    checkpoint.save(rundir.networks_dir(run, "stage3"), 2, {
        **{k: {"params": v.params, "batch_stats": v.batch_stats} for k, v in nets.items()},
        "threshold": np.float32(0.5), "calibration": np.array([0.0, 0.0, 0.8], np.float32)})
    return run


@pytest.fixture
def frame_files(tmp_path):
    """A valid frame (the table seen from 0.5 m straight above) as files -> {name: path}."""
    from vags_jax.predict import frames

    pose = _down_pose(0.0, 0.0, 0.5)
    depth = _table_frame(FRAME_CAM, pose)
    rgb = np.full(depth.shape + (3,), 128, np.uint8)
    paths = frames.write_frame(str(tmp_path / "frame"), rgb, depth, pose, FRAME_CAM, C.tiny().workspace)
    return paths


def _write_text(path, obj):
    with open(path, "w") as f:
        f.write(obj if isinstance(obj, str) else json.dumps(obj))
    return str(path)


def _save(path, array):
    from vags_jax.benchmark.images import save_png

    if str(path).endswith(".npy"):
        np.save(path, array)
    else:
        save_png(str(path), array)
    return str(path)


def _pose_file(tmp, pose):
    return _write_text(tmp / "p.json", {"camera_to_world": np.asarray(pose).tolist()})


PREDICT_CASES = {
    # files
    "rgb-missing": (lambda t, f: {"--rgb": str(t / "none.png")}, r"colour image .*none\.png: no such file"),
    "depth-missing": (lambda t, f: {"--depth": str(t / "none.png")}, r"depth image .*none\.png: no such file"),
    "pose-missing": (lambda t, f: {"--pose": str(t / "none.json")}, r"pose .*none\.json: no such file"),
    "rgb-jpeg": (lambda t, f: {"--rgb": _write_text(t / "c.jpg", "x")}, r"must be a \.png .* or \.npy .*convert"),
    "rgb-not-png": (lambda t, f: {"--rgb": _write_text(t / "c.png", "not a png")}, r"c\.png is not a PNG file"),
    # dtypes and shapes
    "depth-8-bit": (lambda t, f: {"--depth": _save(t / "d.png", np.full((24, 32), 200, np.uint8))},
                    r"d\.png is an 8-bit PNG; depth must be a 16-bit grey PNG in millimetres"),
    "depth-colour": (lambda t, f: {"--depth": _save(t / "d.png", np.zeros((24, 32, 3), np.uint8))},
                     r"d\.png is a colour image .*16-bit grey PNG in millimetres"),
    "depth-npy-uint16": (lambda t, f: {"--depth": _save(t / "d.npy", np.full((24, 32), 500, np.uint16))},
                         r"d\.npy holds uint16 values; depth in a \.npy file must be float metres"),
    "depth-npy-mm": (lambda t, f: {"--depth": _save(t / "d.npy", np.full((24, 32), 500.0, np.float32))},
                     r"global frame: depth values reach 500.*millimetres; divide by 1000"),
    "depth-npy-3d": (lambda t, f: {"--depth": _save(t / "d.npy", np.ones((24, 32, 3), np.float32))},
                     r"d\.npy has shape \(24, 32, 3\); the depth image must be \(height, width\)"),
    "depth-as-rgb": (lambda t, f: {"--rgb": f["depth"]}, r"is a 16-bit PNG \(is it the depth image\?\)"),
    "rgb-grey": (lambda t, f: {"--rgb": _save(t / "c.png", np.zeros((24, 32), np.uint8))}, r"c\.png is a grey image"),
    "rgb-npy-float": (lambda t, f: {"--rgb": _save(t / "c.npy", np.zeros((24, 32, 3), np.float32))},
                      r"c\.npy holds float32 values; the colour image must be uint8"),
    "rgb-other-size": (lambda t, f: {"--rgb": _save(t / "c.png", np.zeros((48, 64, 3), np.uint8))},
                       r"c\.png is 64 x 48 pixels but the depth image .* are 32 x 24: register the colour image"),
    # depth without data
    "depth-all-zero": (lambda t, f: {"--depth": _save(t / "d.png", np.zeros((24, 32), np.uint16))},
                       r"d\.png holds no valid depth \(every pixel is 0 or NaN\); check the depth stream"),
    "depth-all-nan": (lambda t, f: {"--depth": _save(t / "d.npy", np.full((24, 32), np.nan, np.float32))},
                      r"d\.npy holds no valid depth"),
    # poses
    "pose-not-rigid": (lambda t, f: {"--pose": _pose_file(t, np.diag([2.0, -2, -2, 1]) + np.eye(4)[:, 3:] @ [[0, 0, 0.5, 0]])},
                       r"global frame: cam_pose must be a rigid transform"),
    "pose-3x4": (lambda t, f: {"--pose": _write_text(t / "p.json", [[1, 0, 0, 0]] * 3)}, r"p\.json: the pose must be a 4 x 4 list"),
    "pose-not-json": (lambda t, f: {"--pose": _write_text(t / "p.json", "[[1, 0")}, r"pose .*p\.json is not valid JSON"),
    "pose-extrinsics": (lambda t, f: {"--depth": _save(t / "d.npy", _table_frame(FRAME_CAM, _look_at_pose())),
                                      "--pose": _pose_file(t, np.linalg.inv(_look_at_pose()))},
                        r"global frame: .*below the table top .*world-to-camera given instead of camera-to-world"),
    "pose-millimetres": (lambda t, f: {"--pose": _pose_file(t, _moved(_down_pose(0, 0, 0.5), [0, 0, 500.0]))},
                         r"global frame: cam_pose puts the camera 500 m .*millimetres"),
    "pose-off-workspace": (lambda t, f: {"--pose": _pose_file(t, _down_pose(3.0, 3.0, 0.5))},
                           r"global frame: none of the 768 valid depth points falls inside the workspace"),
    # intrinsics
    "intrinsics-other-size": (lambda t, f: {"--intrinsics": _write_text(t / "K.json", {
        "fx": 61.8, "fy": 61.8, "cx": 32, "cy": 24, "width": 64, "height": 48})},
        r"depth\.png is 32 x 24 pixels but .*K\.json says width 64, height 48: give the intrinsics of the stream"),
    "intrinsics-missing-key": (lambda t, f: {"--intrinsics": _write_text(t / "K.json", {"fx": 30.9, "fy": 30.9, "width": 32,
                                                                                  "height": 24})},
                               r"K\.json: intrinsics need exactly the keys fx, fy, cx, cy, width, height .*missing \['cx', 'cy'\]"),
    "intrinsics-typo": (lambda t, f: {"--intrinsics": _write_text(t / "K.json", {"fx": 30.9, "fy": 30.9, "cx": 16, "cy": 12,
                                                                           "width": 32, "heigth": 24})},
                        r"missing \['height'\]"),
    "intrinsics-cx-outside": (lambda t, f: {"--intrinsics": _write_text(t / "K.json", {"fx": 30.9, "fy": 30.9, "cx": 320,
                                                                                 "cy": 12, "width": 32, "height": 24})},
                              r"K\.json: Camera\.cx must be in \[0, 32\]"),
    "intrinsics-width-float": (lambda t, f: {"--intrinsics": _write_text(t / "K.json", {"fx": 30.9, "fy": 30.9, "cx": 16,
                                                                                  "cy": 12, "width": 32.5, "height": 24})},
                               r"K\.json: width must be a whole number, got 32\.5"),
    # the run
    "run-missing": (lambda t, f: {"--run": str(t / "none")}, r"run directory .*none' does not exist"),
    "workspace-size": (lambda t, f: {"--workspace": _write_text(t / "ws.json", {"size": 0.5})},
                       r"workspace\.size = 0\.5 differs from the run's 0\.448: its networks learned on that grid"),
    "workspace-unknown": (lambda t, f: {"--workspace": _write_text(t / "ws.json", {"centre": [0, 0]})},
                          r"ws\.json: unknown workspace keys \['centre'\]"),
    "set-net": (lambda t, f: {"--set": "net.small_width=16"}, r"net\.small_width: the trained networks fix net\.\*"),
    "set-workspace": (lambda t, f: {"--set": "workspace.table_z=0.1"}, r"workspace\.table_z: give the workspace with --workspace"),
    "no-ggcnn": (lambda t, f: {"--set": "vags.local_planner=ggcnn"},
                 r"vags\.local_planner=ggcnn needs a GG-CNN in the run .*train\.py --stage ggcnn"),
    "threshold-and-no-viewpoint": (lambda t, f: {"--threshold": "1", "--no-viewpoint": None},
                                   r"--no-viewpoint fixes the threshold at -inf: drop --threshold"),
    "threshold-nan": (lambda t, f: {"--threshold": "nan"}, r"--threshold must be a finite number"),
    "threshold-text": (lambda t, f: {"--threshold": "high"}, r"argument --threshold: invalid float value: 'high'"),
    "out-image-dir": (lambda t, f: {"--out-image": str(t)}, r"--out-image .* is a directory"),
    # the close frame
    "local-not-rigid": (lambda t, f: {"--local": [f["rgb"], f["depth"], _pose_file(t, np.diag([1.0, -1, -1, 1]) * 1.5)]},
                        r"close frame \(--local\): cam_pose must be a rigid transform"),
    "local-missing": (lambda t, f: {"--local": [f["rgb"], str(t / "none.png"), f["pose"]]},
                      r"depth image .*none\.png: no such file"),
}


def _predict_argv(run, files, changes):
    args = {"--run": run, "--rgb": files["rgb"], "--depth": files["depth"], "--intrinsics": files["intrinsics"],
            "--pose": files["pose"]}
    args.update(changes)
    argv = []
    for k, v in args.items():
        argv += [k] + ([] if v is None else v if isinstance(v, list) else [v])
    return argv


@pytest.mark.parametrize("kind", sorted(PREDICT_CASES))
def test_predict_bad_input_names_the_fix(kind, vags_run, frame_files, tmp_path, capsys):
    change, msg = PREDICT_CASES[kind]
    code, line = _cli(_predict_main, _predict_argv(vags_run, frame_files, change(tmp_path, frame_files)), capsys)
    assert code == 2 and line.startswith("predict: error: ") and re.search(msg, line), line


def test_predict_on_a_run_without_the_needed_networks(tmp_path, capsys, fake_run, frame_files, vags_run):
    """A stage-1 run has no VANet; a run from before the success net cannot use the success gate."""
    run = fake_run(tmp_path)
    code, line = _cli(_predict_main, _predict_argv(run, frame_files, {}), capsys)
    assert code == 2 and f"run {run} has no VANet yet" in line and "or pass --no-viewpoint" in line
    old = str(tmp_path / "old")
    shutil.copytree(vags_run, old)
    from vags_jax.stages import rundir

    d = rundir.networks_dir(old, "stage3")
    arrays, _ = checkpoint.read(d, 2)
    shutil.rmtree(d)
    checkpoint.save(d, 2, {k: v for k, v in arrays.items() if k not in ("success", "calibration")})
    code, line = _cli(_predict_main, _predict_argv(old, frame_files, {}), capsys)
    assert code == 2 and "have no success net" in line and "--set vags.gate=q" in line
    # A run from before the mean success after a move was kept: calibration of 2 entries.
    shutil.rmtree(d)
    checkpoint.save(d, 2, {**arrays, "calibration": np.zeros(2, np.float32)})
    code, line = _cli(_predict_main, _predict_argv(old, frame_files, {}), capsys)
    assert code == 2 and "keep no mean success after a move" in line and "vags.view_estimate=vanet" in line


@pytest.mark.parametrize("argv,msg", [
    (["write-frames", "--config", "tiny", "--out", "{tmp}/f", "--objects", "9"], r"--objects 9 exceeds scene\.max_objects = 3"),
    (["write-frames", "--config", "tiny", "--out", "{tmp}/f", "--at", "{tmp}/none.json"], r"pose .*none\.json: no such file"),
    (["write-frames", "--run", "{tmp}/none", "--out", "{tmp}/f"], r"run directory .* does not exist"),
    (["write-frames", "--config", "tiny", "--run", "{tmp}", "--out", "{tmp}/f"], r"--run uses the run's own config\.json"),
    (["write-frames", "--config", "tiny"], r"the following arguments are required: --out"),
    (["write-frames", "--config", "tiny", "--out", "{tmp}/f", "--at", "{tmp}/move.json"],
     r"move\.json is a predict output without a viewpoint \(decision 'grasp'\)"),
    (["execute", "--config", "tiny", "--grasp", "{tmp}/move.json"], r"--grasp .*move\.json: decision 'grasp' without a grasp"),
    (["execute", "--config", "tiny", "--grasp", "{tmp}/none.json"], r"--grasp .*none\.json: no such file"),
])
def test_predict_simulator_commands_check_their_inputs(argv, msg, tmp_path, capsys):
    _write_text(tmp_path / "move.json", {"decision": "grasp"})
    code, line = _cli(_predict_main, [a.format(tmp=tmp_path) for a in argv], capsys)
    assert code == 2 and line.startswith("predict ") and re.search(msg, line), line


@pytest.mark.skipif(jax.default_backend() == "gpu", reason="the Warp renderer runs on a GPU")
@pytest.mark.parametrize("command", [["write-frames", "--out", "{tmp}/f"], ["execute", "--grasp", "{tmp}/g.json"]])
def test_predict_simulator_commands_refuse_the_warp_renderer_off_a_gpu(command, tmp_path, capsys):
    """A run trained on a GPU (the gpu presets render with Warp) simulated on a CPU: one line naming
    --set camera.renderer=jax, before anything is built (it was a traceback from the renderer)."""
    _write_text(tmp_path / "g.json", {"decision": "grasp", "grasp": {"position": [0, 0, 0.05], "yaw": 0}})
    argv = [a.format(tmp=tmp_path) for a in command] + ["--config", "tiny", "--set", "camera.renderer=warp"]
    code, line = _cli(_predict_main, argv, capsys)
    assert code == 2 and line.startswith("predict ") and "--set camera.renderer=jax" in line, line


def test_predict_exit_code_2_one_line(frame_files, vags_run, tmp_path):
    """As a real command: exit code 2, one stderr line, no traceback."""
    argv = _predict_argv(vags_run, frame_files, {"--depth": str(tmp_path / "none.png")})
    p = subprocess.run([sys.executable, "-m", "vags_jax.predict"] + argv, cwd=ROOT, capture_output=True, text=True,
                       timeout=120, env={**os.environ, "PYTHONPATH": ROOT + os.pathsep + os.environ.get("PYTHONPATH", "")})
    assert p.returncode == 2, p.stderr
    assert re.search(r"^predict: error: depth image .*none\.png: no such file", _one_line(p.stderr))


def test_networks_of_a_stage_the_run_lacks_is_one_line(capsys, vags_run):
    code, line = _cli(eval_cli.main, ["--run", vags_run, "--networks", "stage2"], capsys)
    assert code == 2 and f"run {vags_run} has no stage2 networks (it has stage3's)" in line, line


def test_eval_without_viewpoints_plans_without_a_gate_table(tmp_path, vags_run):
    """eval.py --no-viewpoint under the rate gate accepts a run that has no table for its networks
    (its planning once asked for one though the ablation never moves)."""
    from vags_jax.benchmark import requests as eval_requests

    run = str(tmp_path / "run")
    shutil.copytree(vags_run, run)
    plan = eval_requests.prepare_eval(eval_cli.parse_args(["--run", run, "--no-viewpoint", "--set", "vags.gate=rate"]))
    assert plan.name == "vags-no-viewpoint" and plan.networks.gate_table is None
    with pytest.raises(ValueError, match="needs the run's measured gate table"):
        eval_requests.prepare_eval(eval_cli.parse_args(["--run", run, "--set", "vags.gate=rate"]))


def test_the_rate_gate_without_a_table_for_the_runs_networks_says_how_to_measure_one(tmp_path, capsys, vags_run,
                                                                                     frame_files):
    from types import SimpleNamespace

    from vags_jax.policies import rate_gate
    from vags_jax.policies.catalog import vags_params
    from vags_jax.stages import gate_measure

    run = str(tmp_path / "run")
    shutil.copytree(vags_run, run)
    code, line = _cli(eval_cli.main, ["--run", run, "--policy", "vags", "--set", "vags.gate=rate"], capsys)
    assert code == 2 and f"{run} has no gate.json: measure it with python -m vags_jax.stages.gate_measure" in line, line
    code, line = _cli(_predict_main, _predict_argv(run, frame_files, {"--set": ["vags.gate=rate"]}), capsys)
    assert code == 2 and "needs a gate table measured on the run's networks (stage3 step 2)" in line, line
    # A table measured on networks the run no longer has is not used (rundir.load_vags reads None).
    rate_gate.save(run, rate_gate.GateTable((0.5,), (1, 1), (0.5, 0.9), (0.8, 0.8), (1.0, 1.0), 0.1, (0.2, -0.2)),
                   {"networks": "stage3 step 1"})
    code, line = _cli(_predict_main, _predict_argv(run, frame_files, {"--set": ["vags.gate=rate"]}), capsys)
    assert code == 2 and "gate table measured on the run's networks (stage3 step 2)" in line, line
    stale = SimpleNamespace(success=(), ggcnn=None, calibration=None, q_threshold=0.0, gdnet=None, vanet=None,
                            gate_table=rate_gate.load(run, "stage3 step 2"), source="stage3 step 2")
    with pytest.raises(ValueError, match=r"measure it with python -m vags_jax\.stages\.gate_measure --run RUN"):
        vags_params(stale, C.replace(C.tiny(), **{"vags.gate": "rate"}))
    # GDNet alone (eval.py --no-viewpoint, threshold -inf) never moves, so it needs no table.
    ablation = vags_params(stale, C.replace(C.tiny(), **{"vags.gate": "rate"}), threshold=-math.inf)
    assert np.array_equal(np.asarray(ablation["gate_table"]), [[np.inf], [0.0]])
    code, line = _cli(gate_measure.main, ["--run", run, "--worlds", "0"], capsys)
    assert code == 2 and line == "python -m vags_jax.stages.gate_measure: --worlds must be at least 1, got 0"
    code, line = _cli(gate_measure.main, ["--run", str(tmp_path / "none")], capsys)
    assert code == 2 and line.startswith("python -m vags_jax.stages.gate_measure: ") and "none" in line, line
    code, line = _cli(gate_measure.main, ["--run", run, "--cache-dir", "/proc/version"], capsys)
    assert code == 2 and "--cache-dir '/proc/version': cannot create it" in line, line


# ----------------------------------------------------------------------------- out of accelerator memory

_OOM = "RESOURCE_EXHAUSTED: Out of memory while trying to allocate 11.17GiB with allocator GPU_0_bfc on device 0."


class _FailedToken:
    """The runtime token of a program with side effects (MJX's Warp calls) that failed on the device."""

    def block_until_ready(self):
        raise jax.errors.JaxRuntimeError(_OOM)


@pytest.fixture
def failed_runtime_token():
    """JAX's token set holding a failed token, as after the out-of-memory of a Warp run on an H200:
    JAX's exit handlers (``dispatch.wait_for_tokens``, ``api.clean_up``) then printed two tracebacks
    after train.py's one-line error.  Yields ``jax._src.dispatch``; clears the set afterwards."""
    from jax._src import dispatch

    dispatch.runtime_tokens.output_runtime_tokens["a device"] = _FailedToken()
    with pytest.raises(jax.errors.JaxRuntimeError):  # what the exit handler would do now
        jax.effects_barrier()
    dispatch.runtime_tokens.output_runtime_tokens["a device"] = _FailedToken()  # whether or not that dropped it
    yield dispatch
    dispatch.runtime_tokens.clear()


def test_eval_out_of_memory_is_one_line_saying_what_to_lower(monkeypatch, capsys, failed_runtime_token):
    """XLA's out-of-memory error while playing (e.g. two evaluations sharing a GPU) ends eval.py
    with exit code 1 and one line naming the allocation and what to lower, not a traceback;
    any other runtime error keeps its traceback."""
    def oom(*a, **k):
        raise jax.errors.JaxRuntimeError(_OOM)

    monkeypatch.setattr(eval_cli.E, "evaluate", oom)
    code = eval_cli.main(["--config", "tiny", "--policy", "heuristic", "--groups", "1", "--rounds", "1"])
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert code == 1
    assert last.startswith("eval.py: error: out of accelerator memory (Out of memory while trying to allocate 11.17GiB")
    assert "--rounds" in last and "net.forward_batch" in last and "XLA_PYTHON_CLIENT_MEM_FRACTION" in last
    failed_runtime_token.wait_for_tokens()  # JAX's atexit handler

    def other(*a, **k):
        raise jax.errors.JaxRuntimeError("INTERNAL: something else")

    monkeypatch.setattr(eval_cli.E, "evaluate", other)
    with pytest.raises(jax.errors.JaxRuntimeError, match="something else"):
        eval_cli.main(["--config", "tiny", "--policy", "heuristic", "--groups", "1", "--rounds", "1"])


def test_gate_measure_out_of_memory_is_one_line(monkeypatch, tmp_path, capsys, failed_runtime_token):
    from vags_jax.stages import gate_measure

    def oom(*a, **k):
        raise jax.errors.JaxRuntimeError(_OOM)

    monkeypatch.setattr(gate_measure, "measure_picked", oom)
    code, line = _cli(gate_measure.main, ["--run", str(tmp_path)], capsys)
    assert code == 1 and line.startswith("python -m vags_jax.stages.gate_measure: error: out of accelerator memory "
                                         "(Out of memory while trying to allocate 11.17GiB"), line
    assert "lower --worlds" in line and f"{tmp_path}/gate.json is unchanged" in line, line
    failed_runtime_token.wait_for_tokens()  # JAX's atexit handler
