"""GG-CNN's physics-labelled dataset, its cache, and ``train.py --stage ggcnn`` (tiny config, CPU).

Compile time dominates: every test shares one ``DataMaker`` (the session's ``Programs``: the two
compiled programs, scenes + views + candidates and grasps in scene copies), train.py's run
included, and the dataset is made once per module (2 scenes of 4 candidates per batch).
"""
from __future__ import annotations

import json
import math
import os

os.environ.setdefault("JAX_PLATFORMS", "cpu")

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import train
from vags_jax.stages import checkpoint, ggcnn as ggcnn_stage, requests
from vags_jax import config as C
from vags_jax.ggcnn import data as ggcnn_data
from vags_jax.nets.ggcnn import init_ggcnn

from conftest import FAST_PHYSICS

# On conftest's FAST_PHYSICS (boxes, pyramidal cones: the data maker's programs compile faster);
# every check here holds whatever the contacts are (labels are what re-executed grasps give).
FAST = C.parse_overrides(FAST_PHYSICS)
OVERRIDES = {
    **FAST,
    "ggcnn_data.views": 4,
    "ggcnn_data.heldout_views": 2,
    "ggcnn_data.candidates": 4,
    "ggcnn_data.scenes_per_batch": 2,
    "ggcnn.train_steps": 20,
    "ggcnn.batch_size": 4,
}
SET = [f"{k}={v}" for k, v in OVERRIDES.items() if k not in FAST] + FAST_PHYSICS  # train.py's --set strings


@pytest.fixture(scope="module")
def cfg():
    return C.replace(C.tiny(), **OVERRIDES)


@pytest.fixture(scope="module")
def maker(cfg, programs):
    return programs.data_maker(cfg)


@pytest.fixture(scope="module")
def data_dir(tmp_path_factory):
    return str(tmp_path_factory.mktemp("ggcnn_cache"))


@pytest.fixture(scope="module")
def made(cfg, maker, data_dir):
    logs = []
    return ggcnn_data.load_or_make(cfg, maker, data_dir, logs.append), logs


def test_dataset_shapes_dtypes_and_counts(cfg, made):
    ds, logs = made
    assert any("no cache" in l for l in logs) and not ds.info["reused"]
    p, k = cfg.ggcnn.input_size, cfg.ggcnn_data.candidates
    for vs, n in ((ds.train, 4), (ds.heldout, 2)):
        assert vs.x.shape == (n, p, p) and vs.x.dtype == np.float16
        assert np.all(np.abs(vs.x) <= 1.0) and np.isfinite(vs.x).all()
        assert vs.center.shape == (n, k, 2) and vs.center.dtype == np.float32
        assert np.array_equal(vs.center, np.round(vs.center)) and vs.center.min() >= 0 and vs.center.max() <= p - 1
        for name in ("angle", "length", "jaw", "gap"):
            assert getattr(vs, name).shape == (n, k) and getattr(vs, name).dtype == np.float32
        assert vs.success.shape == (n, k) and vs.success.dtype == bool
        assert np.all(vs.angle >= -math.pi / 2) and np.all(vs.angle < math.pi / 2)
        assert vs.n_objects.min() >= 1 and vs.n_objects.max() <= 3
        assert np.all(vs.length > 0) and np.all(vs.jaw > 0)
    t = ds.info["train"]
    assert t["views"] == 4 and t["grasps_tried"] == 16
    assert t["success_share"] == pytest.approx(ds.train.success.mean())
    assert ds.info["version"] == ggcnn_data.DATA_VERSION and ds.info["seconds"] > 0


def test_labels_come_from_physics(cfg, maker, made):
    ds, _ = made
    d = cfg.ggcnn_data
    # Object-centred candidates in 1-3 object scenes: some succeed (fixed seed).
    assert ds.train.success.any()
    # Width labels: the measured pad gap (+ margin) at the same depth and fx as the jaw:
    # length / jaw = (gap + width_margin) / jaw for every success.
    ok = ds.train.success
    assert np.all(ds.train.gap[ok] > cfg.grasp.closed_gap) and np.all(ds.train.gap[~ok] == 0)
    np.testing.assert_allclose((ds.train.length / ds.train.jaw)[ok], (ds.train.gap[ok] + d.width_margin) / d.jaw,
                               rtol=1e-4)

    # The held-out stream's first batch again: the same views as the stored held-out ones.
    key = ggcnn_data.stream_keys(cfg, ggcnn_data.HELDOUT_STREAM, 1)[0]
    v = maker.render(key)
    np.testing.assert_array_equal(np.asarray(v.x.astype(jnp.float16)), ds.heldout.x[:2])
    np.testing.assert_array_equal(np.asarray(v.center), ds.heldout.center[:2])
    # Candidates of views that show objects sit on them: the surface at the centre is above
    # the table by more than the object threshold.
    surface = np.asarray(v.position[..., 2]) + cfg.grasp.depth_below_surface
    assert np.all(surface[np.asarray(v.object_view)] > cfg.workspace.table_z + cfg.exploration.height_threshold)

    # A grasp on bare table (the workspace corner farthest from every object) fails; the
    # candidates of scene 0, executed again, give the stored labels.
    pos = np.asarray(maker.env.sim.object_positions(v.sim))  # (S, P, 3)
    active = np.asarray(v.sim.active)
    xmin, xmax, ymin, ymax = cfg.workspace.bounds
    corners = np.array([[x, y] for x in (xmin + 0.03, xmax - 0.03) for y in (ymin + 0.03, ymax - 0.03)])
    bare = []
    for s in range(2):
        objects = pos[s][active[s]][:, :2]  # (n, 2)
        dist = np.linalg.norm(corners[:, None] - objects[None], axis=-1).min(axis=1)  # (4,)
        assert dist.max() > 0.1
        bare.append([*corners[np.argmax(dist)], cfg.workspace.table_z])
    w = maker.worlds
    scene = np.array([0, 1] + [0] * d.candidates + [1] * (w - 2 - d.candidates), np.int32)
    position = np.concatenate([np.array(bare, np.float32), np.asarray(v.position[0]),
                               np.repeat(np.asarray(v.position[1, :1]), w - 2 - d.candidates, 0)])
    yaw = np.concatenate([np.zeros(2, np.float32), np.asarray(v.yaw[0]),
                          np.repeat(np.asarray(v.yaw[1, :1]), w - 2 - d.candidates)])
    start = np.asarray(v.pose[:, :3, 3])[scene]
    success, gap, error = jax.device_get(maker.execute(v.sim, jnp.asarray(scene), jnp.asarray(position),
                                                       jnp.asarray(yaw), jnp.asarray(start)))
    assert not error.any()
    assert not success[:2].any() and np.all(gap[:2] <= cfg.grasp.closed_gap)
    np.testing.assert_array_equal(success[2:2 + d.candidates], ds.heldout.success[0])


def test_candidates_fall_back_to_valid_pixels():
    obj = np.zeros((2, 12, 12), bool)
    obj[0, 3:5, 6:9] = True  # view 0 shows an object; view 1 none
    valid = np.zeros((2, 12, 12), bool)
    valid[1, 8, 2] = valid[1, 1, 10] = True
    center, angle, has_obj = ggcnn_data.sample_candidates(jax.random.PRNGKey(3), jnp.asarray(obj),
                                                          jnp.asarray(valid), 64)
    center = np.asarray(center).astype(int)
    assert np.asarray(has_obj).tolist() == [True, False]
    assert obj[0, center[0, :, 1], center[0, :, 0]].all()
    assert valid[1, center[1, :, 1], center[1, :, 0]].all()
    assert len({tuple(c) for c in center[1]}) == 2  # both valid pixels drawn
    assert np.all(np.abs(np.asarray(angle)) <= math.pi / 2)


def test_cache_is_reused_and_keyed_by_config(cfg, maker, made, data_dir):
    ds, _ = made
    logs = []
    again = ggcnn_data.load_or_make(cfg, maker, data_dir, logs.append)
    assert again.info["reused"] and any("reusing" in l for l in logs)
    for a, b in ((ds.train, again.train), (ds.heldout, again.heldout)):
        for name, arr in a.arrays().items():
            np.testing.assert_array_equal(arr, getattr(b, name))
    # Training-only fields share the data; anything that changes the views does not.
    same = C.replace(cfg, **{"ggcnn.learning_rate": 1e-4, "ggcnn.train_steps": 7, "dqn.gamma": 0.3})
    assert ggcnn_data.cache_path(same, data_dir) == ds.info["path"]
    for change in ({"seed": 1}, {"ggcnn_data.views": 2}, {"camera.noise.enabled": False},
                   {"ggcnn_data.jaw": 0.03}, {"ggcnn.input_size": 36}):
        assert ggcnn_data.cache_path(C.replace(cfg, **change), data_dir) != ds.info["path"], change
    other = C.replace(cfg, **{"ggcnn_data.views": 2})  # same programs, another dataset
    logs = []
    small = ggcnn_data.load_or_make(other, maker, data_dir, logs.append)
    assert not small.info["reused"] and any("no cache" in l for l in logs)
    assert small.train.n == 2 and small.info["path"] != ds.info["path"]
    np.testing.assert_array_equal(small.train.x, ds.train.x[:2])  # the same training stream
    with pytest.raises(ValueError, match="another config"):
        ggcnn_data.load_or_make(C.replace(cfg, **{"ggcnn_data.jaw": 0.03}), maker, data_dir)


def test_damaged_cache_is_named_and_remade(cfg, maker, made, data_dir):
    other = C.replace(cfg, **{"ggcnn_data.views": 2})
    path = ggcnn_data.cache_path(other, data_dir)
    if not os.path.exists(os.path.join(path, ggcnn_data.META_FILE)):
        ggcnn_data.load_or_make(other, maker, data_dir)
    good = ggcnn_data.read_cache(other, path)
    views = os.path.join(path, ggcnn_data.VIEWS_FILE)
    with open(views, "r+b") as f:
        f.truncate(os.path.getsize(views) // 2)
    with pytest.raises(ggcnn_data.DamagedCache, match="views.npz cannot be read"):
        ggcnn_data.read_cache(other, path)
    logs = []
    remade = ggcnn_data.load_or_make(other, maker, data_dir, logs.append)
    assert any("damaged" in l and "making it again" in l for l in logs) and not remade.info["reused"]
    np.testing.assert_array_equal(remade.train.success, good.train.success)
    meta = os.path.join(path, ggcnn_data.META_FILE)
    with open(meta, "w") as f:
        f.write("{not json")
    with pytest.raises(ggcnn_data.DamagedCache, match="meta.json is not valid JSON"):
        ggcnn_data.read_cache(other, path)
    with open(meta, "w") as f:
        json.dump({"version": ggcnn_data.DATA_VERSION + 1}, f)
    with pytest.raises(ggcnn_data.DamagedCache, match="data version"):
        ggcnn_data.read_cache(other, path)


def test_train_stage_ggcnn_end_to_end(cfg, maker, made, data_dir, tmp_path, capsys, programs):
    ds, _ = made
    run = str(tmp_path / "run")
    args = ["--config", "tiny", "--stage", "ggcnn", "--out", run, "--data-dir", data_dir, "--quiet", "--json", "--set", *SET]
    assert train.main(args, programs) == 0
    out, err = capsys.readouterr()
    assert "reusing the cache" in err
    summary = json.loads(out.strip().splitlines()[-1])
    with open(os.path.join(run, "summary.json")) as f:
        assert json.load(f) == summary
    assert "next:" in err and f"python eval.py --run {run} --policy ggcnn" in err
    assert summary["data_reused"] and summary["steps"] == 20
    gdir = os.path.join(run, "ggcnn")
    assert checkpoint.checkpoint_steps(gdir) == [20]
    with open(os.path.join(gdir, "metrics.json")) as f:
        info = json.load(f)
    acc = info["heldout_accuracy"]
    for k in ("ggcnn_success", "label_peak_success", "candidate_success", "views_with_success"):
        assert 0.0 <= acc[k] <= 1.0 and acc[k] == summary[k]
    assert acc["views"] == 2
    # Held-out scenes are the held-out views' scenes: the same candidate base rate.
    assert acc["candidate_success"] == pytest.approx(ds.heldout.success.mean())
    assert math.isfinite(info["training"]["heldout_loss"]) and len(info["training"]["history"]) == 10
    assert checkpoint.load_config(gdir) == cfg

    params, step = ggcnn_stage.load_ggcnn(run)
    assert step == 20
    again, _ = ggcnn_stage.train_ggcnn(cfg, ds, ggcnn_stage.train_key(cfg), chunk=2)
    assert checkpoint.tree_equal(params, again)  # saved exactly, and training is deterministic
    assert not checkpoint.tree_equal(params, init_ggcnn(jax.random.PRNGKey(0), size=12))

    # Stage 1 may still start in this run directory; a second GG-CNN may not.
    plan = requests.prepare_stage1(train.parse_args(["--config", "tiny", "--out", run]))
    assert plan.step == 0
    assert train.main(args) == 2
    err = capsys.readouterr().err
    assert "already holds a GG-CNN" in err and len(err.strip().splitlines()) == 1


def test_load_ggcnn_errors(tmp_path):
    run = str(tmp_path / "run")
    os.makedirs(run)
    with pytest.raises(checkpoint.CheckpointError,
                       match=r"has no GG-CNN checkpoint .*train one with python train.py --stage ggcnn --out"):
        ggcnn_stage.load_ggcnn(run)
    params = init_ggcnn(jax.random.PRNGKey(1), size=12)
    ggcnn_stage.save_ggcnn(run, params, {"steps": 5})
    got, step = ggcnn_stage.load_ggcnn(run)
    assert step == 5 and checkpoint.tree_equal(got, params)
    with pytest.raises(checkpoint.CheckpointError, match=r"no GG-CNN checkpoint 7 .*holds \[5\]"):
        ggcnn_stage.load_ggcnn(run, step=7)

    wrong = str(tmp_path / "wrong")
    ggcnn_stage.save_ggcnn(wrong, {"params": {"w": jnp.zeros((3,))}}, {"steps": 1})
    with pytest.raises(checkpoint.CheckpointError, match="does not hold GG-CNN's parameters"):
        ggcnn_stage.load_ggcnn(wrong)

    meta = os.path.join(run, "ggcnn", "checkpoints", "5", "default", "_METADATA")
    with open(meta, "w") as f:
        f.write("{garbled")
    with pytest.raises(checkpoint.CheckpointError, match=r"cannot be used: .*damaged.*train it again") as e:
        ggcnn_stage.load_ggcnn(run)
    assert "\n" not in str(e.value)


def test_ggcnn_reuse_checks_the_label_rule(tmp_path):
    from vags_jax.stages import rundir as pipeline

    cfg = C.replace(C.tiny(), **{"ggcnn.labels": "success_ratio"})
    run = str(tmp_path / "run")
    ggcnn_stage.save_ggcnn(run, init_ggcnn(jax.random.PRNGKey(1), size=12), {"steps": 1}, cfg)
    assert pipeline.ggcnn_reusable(run, cfg) is None
    assert "another config" in pipeline.ggcnn_reusable(run, C.replace(cfg, **{"ggcnn.labels": "positives"}))
    # A GG-CNN saved before ggcnn.labels existed learnt GG-CNN's positives, whatever the default.
    path = os.path.join(run, "ggcnn", checkpoint.CONFIG_FILE)
    with open(path) as f:
        saved = json.load(f)
    del saved["ggcnn"]["labels"]
    with open(path, "w") as f:
        json.dump(saved, f)
    assert "another config" in pipeline.ggcnn_reusable(run, cfg)
    assert pipeline.ggcnn_reusable(run, C.replace(cfg, **{"ggcnn.labels": "positives"})) is None


@pytest.mark.parametrize("argv, match", [
    (["--stage", "nope"], "invalid choice: 'nope'"),
    (["--stage", "ggcnn", "--resume"], "drop --resume"),
    (["--stage", "ggcnn", "--max-minutes", "3"], "--max-minutes apply to --stage gdnet only"),
    (["--stage", "gdnet", "--data-dir", "x"], "--data-dir is for GG-CNN (--stage ggcnn, or the whole pipeline)"),
    (["--stage", "ggcnn", "--set", "ggcnn.crop_size=200"], "ggcnn.crop_size = 200 exceeds the camera image"),
    (["--stage", "ggcnn", "--set", "ggcnn_data.candidates=0"], "ggcnn_data.candidates must be in"),
])
def test_stage_flags_are_checked_before_compiling(tmp_path, capsys, argv, match):
    try:
        code = train.main(["--config", "tiny", "--out", str(tmp_path / "r"), *argv])
    except SystemExit as e:
        code = e.code
    assert code == 2
    err = capsys.readouterr().err.strip()
    assert match in err and len(err.splitlines()) == 1
    assert not os.path.exists(tmp_path / "r")
