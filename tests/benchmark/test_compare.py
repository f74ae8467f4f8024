"""eval.py --compare (vags_jax.benchmark.compare): Wilson intervals by hand, Table 1 and its files
on hand-made reports, and a tiny comparison whose methods all play the same scenes."""
import csv
import json

import numpy as np
import pytest

import eval as eval_cli
from vags_jax.benchmark import compare as CMP
from vags_jax.benchmark import metrics as M
from vags_jax.stages import checkpoint
from vags_jax import config as C

from conftest import FAST_PHYSICS, TINY_TEST_OVERRIDES


def test_wilson_interval_hand_computed():
    # 8 of 10: centre (0.8 + z^2 / 20) / (1 + z^2 / 10), half z / (1 + z^2 / 10) sqrt(0.016 + z^2 / 400)
    lo, hi = M.wilson_interval(8, 10)
    assert lo == pytest.approx(0.4902, abs=1e-4) and hi == pytest.approx(0.9433, abs=1e-4)
    lo, hi = M.wilson_interval(0, 5)
    assert lo == pytest.approx(0.0, abs=1e-12) and hi == pytest.approx(3.8415 / (5 + 3.8415), abs=1e-4)  # z^2 / (n + z^2)
    assert M.wilson_interval(3, 0) is None


def _report(policy, successes, attempts, cleared, rounds, scenes="abc"):
    m = {"rounds": rounds, "objects": rounds, "attempts": attempts, "successes": successes, "motions": attempts,
         "grasp_success_rate": successes / attempts, "clearing_rate": cleared / rounds, "motion_number": 1.0,
         "picks_per_hour": 600.0, "robot_seconds": 10.0, "attempts_per_round": 1.0, "on_object_rate": 1.0,
         "viewpoint_rate": 0.0, "objects_lost": 0, "physics_errors": 0, "buffer_overflows": 0}
    return {"policy": policy, "seed": 0, "groups": [1], "rounds": rounds, "scenes": scenes,
            "groups_metrics": [dict(m, n_objects=1)], "overall": m}


def test_table1_json_and_csv_from_hand_made_reports(tmp_path):
    reports = {"a": _report("a", 8, 10, 3, 4), "b": _report("b", 0, 5, 0, 4)}
    table = CMP.table1(reports).splitlines()
    assert len(table) == 4 and "| a | 4 | 10 | 80.0 [49.0, 94.3] | 75.0 [" in table[2]
    assert "| b | 4 | 5 | 0.0 [0.0, 43.4] | 0.0 [0.0, " in table[3]
    csv_path = CMP.write_comparison(reports, str(tmp_path / "t1.json"), {"seed": 0})
    with open(csv_path) as f:
        rows = list(csv.DictReader(f))
    assert [(r["method"], r["n_objects"]) for r in rows] == [("a", "1"), ("a", "overall"), ("b", "1"), ("b", "overall")]
    assert float(rows[1]["success_low"]) == pytest.approx(0.4902, abs=1e-4) and rows[1]["cleared"] == "3"
    with open(tmp_path / "t1.json") as f:
        data = json.load(f)
    assert [m["label"] for m in data["methods"]] == ["a", "b"] and data["table1"][0]["success_high"] > 0.94
    CMP.check_same_scenes(reports)
    with pytest.raises(ValueError, match="played other scenes"):
        CMP.check_same_scenes({**reports, "c": _report("c", 1, 1, 1, 4, scenes="xyz")})
    CMP.check_same_scenes({**reports, "c": _report("c", 1, 1, 1, 4, scenes="xyz")}, digests=False)
    with pytest.raises(ValueError, match="played rounds 5"):
        CMP.check_same_scenes({**reports, "c": _report("c", 1, 1, 1, 5)})
    # The scene digest hashes the draws only; the recorded configs' scene settings are compared
    # too (the "edge" variant moves the camera and the drop margin, with the same draws).
    cfg = {"scene": {"drop_margin": 0.1}, "workspace": {"heightmap_px": 224},
           "camera": {"global_position": [0.0, -0.42, 0.62], "renderer": "jax"}}
    edge = json.loads(json.dumps(cfg))
    edge["camera"]["global_position"] = [0.0, -0.34, 0.502]
    same = {"a": dict(reports["a"], config=cfg), "b": dict(reports["b"], config=dict(cfg, camera=dict(
        cfg["camera"], renderer="warp")))}
    CMP.check_same_scenes(same)  # the renderer is not a scene setting
    CMP.check_same_scenes({**same, "c": _report("c", 1, 1, 1, 4)})  # no config recorded: not compared
    with pytest.raises(ValueError, match=r"camera.global_position: \[0.0, -0.34, 0.502\]"):
        CMP.check_same_scenes({**same, "c": dict(_report("c", 1, 1, 1, 4), config=edge)}, digests=False)
    centred = json.loads(json.dumps(cfg))
    centred["camera"]["cx"] = None  # None is a recorded value (the image centre), not a missing one
    with pytest.raises(ValueError, match=r"camera.cx: 300.0 and None"):
        CMP.check_same_scenes({"a": dict(reports["a"], config=centred), "c": dict(
            _report("c", 1, 1, 1, 4), config=dict(centred, camera=dict(centred["camera"], cx=300.0)))})
    edge["scene"]["drop_margin"] = 0.06
    with pytest.raises(ValueError, match=r"\(scene.drop_margin: 0.06 and 0.1\)"):
        CMP.check_same_scenes({**same, "c": dict(_report("c", 1, 1, 1, 4), config=edge)}, digests=False)


def test_compare_plays_every_method_on_the_same_scenes(tmp_path, capsys):
    """Two methods, the heuristic by name (with --run's config) and as RUN:heuristic: one
    compiled program (the config and batch of tests/benchmark/test_evaluate.py's tiny run: one
    round per group, 2 worlds, on conftest's FAST_PHYSICS, so a session's compilation cache serves
    it), and identical rounds, which only the same scenes and seeds give."""
    cfg = C.replace(C.tiny(), **TINY_TEST_OVERRIDES, **C.parse_overrides(FAST_PHYSICS),
                    **{"benchmark.max_attempts_extra": 1})
    run = tmp_path / "run"
    run.mkdir()
    checkpoint.save_config(str(run), cfg)
    out = str(tmp_path / "cmp" / "table1.json")
    argv = ["--run", str(run), "--compare", "heuristic", f"{run}:heuristic", "--groups", "1,2", "--rounds", "1",
            "--out", out]
    assert eval_cli.main(argv) == 0
    table = capsys.readouterr().out
    second = f"heuristic ({run}:heuristic)"
    assert "| heuristic | 2 |" in table and f"| {second} | 2 |" in table
    with open(out) as f:
        data = json.load(f)
    reps = {m["label"]: m["report"] for m in data["methods"]}
    assert list(reps) == ["heuristic", second]
    assert reps["heuristic"]["scenes"] is not None and reps["heuristic"]["scenes"] == reps[second]["scenes"]
    assert json.dumps(reps["heuristic"]["outcomes"]) == json.dumps(reps[second]["outcomes"])
    for rep in reps.values():
        assert rep["seed"] == cfg.seed and rep["groups"] == [1, 2] and rep["rounds"] == 1
        assert [json.dumps(rep["outcomes"][k]["n_objects"]) for k in ("1", "2")] == ["[1]", "[2]"]
    assert [r["method"] for r in data["table1"]] == ["heuristic", second]
    with open(out.replace(".json", ".csv")) as f:
        rows = list(csv.DictReader(f))
    assert [(r["method"], r["n_objects"]) for r in rows] == [
        ("heuristic", "1"), ("heuristic", "2"), ("heuristic", "overall"),
        (second, "1"), (second, "2"), (second, "overall")]
    o = reps["heuristic"]["overall"]
    lo, hi = M.wilson_interval(o["successes"], o["attempts"])
    assert float(rows[2]["success_low"]) == pytest.approx(lo) and float(rows[2]["success_high"]) == pytest.approx(hi)
    # a saved report joins a later table (the driver's pieces); one of other rounds is refused
    one = str(tmp_path / "heuristic.json")
    with open(one, "w") as f:
        json.dump(reps["heuristic"], f)
    assert eval_cli.main(["--compare", one, "--out", str(tmp_path / "again.json")]) == 0
    bad = dict(reps[second], rounds=3)
    with open(tmp_path / "r3.json", "w") as f:
        json.dump(bad, f)
    assert eval_cli.main(["--compare", one, str(tmp_path / "r3.json")]) == 1
    assert "played rounds 3" in capsys.readouterr().err


def test_compare_refuses_a_ggcnn_method_without_a_ggcnn(tmp_path, capsys):
    run = tmp_path / "run"
    run.mkdir()
    checkpoint.save_config(str(run), C.tiny())
    assert eval_cli.main(["--run", str(run), "--compare", "random", "mvp"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("eval.py: error: --compare mvp:")


def test_scenes_digest_is_of_the_draws_not_of_the_settled_poses():
    """The same draws (counts, colours, sizes) with other settled poses (GPU physics is not bit
    for bit repeatable) give the same digest; another size or count gives another one."""
    from types import SimpleNamespace

    from vags_jax.benchmark.protocol import scenes_digest

    def state(qpos, size, n):
        sim = SimpleNamespace(data=SimpleNamespace(qpos=np.asarray(qpos, np.float32)), n_objects=np.array(n, np.int32),
                              geom_rgb=np.full((2, 3, 3), 7, np.uint8), obj_size=np.asarray(size, np.float32))
        return SimpleNamespace(sim=sim)

    size = np.full((2, 4, 3), 0.02)
    a = scenes_digest(state(np.zeros((2, 7)), size, [3, 4]))
    assert a == scenes_digest(state(np.full((2, 7), 1e-4), size, [3, 4]))
    assert a != scenes_digest(state(np.zeros((2, 7)), size * 1.1, [3, 4]))
    assert a != scenes_digest(state(np.zeros((2, 7)), size, [3, 5]))
