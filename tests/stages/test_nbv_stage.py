"""The NBV baseline's stage (train.py --stage nbv): its place among the stages, its refusal before
stage 1 is done (nothing compiled), and its always-moving decision on hand-set GDNet values."""
from types import SimpleNamespace

import jax.numpy as jnp
import numpy as np

import train
from vags_jax import config as C
from vags_jax.nets import nbv_net
from vags_jax.stages import checkpoint, rundir
from vags_jax.stages.stage23 import VagsStage


def test_nbv_is_a_stage_outside_the_pipeline(tmp_path):
    cfg = C.tiny()
    assert rundir.canonical("nbv") == "nbv" and "nbv" not in rundir.ORDER
    assert rundir.prerequisites("nbv") == ("ggcnn", "stage1") and rundir.prerequisites("stage3") == rundir.ORDER[:3]
    assert rundir.total(cfg, "nbv") == cfg.nbv.iterations
    assert rundir.stage_dir("RUN", "nbv") == "RUN/nbv" and rundir.progress(str(tmp_path), "nbv") == 0
    assert nbv_net(C.paper().net).trunk == "small" and nbv_net(C.paper().net).init is None


def test_nbv_needs_stage_one_first(tmp_path, capsys):
    run = tmp_path / "run"
    run.mkdir()
    checkpoint.save_config(str(run), C.tiny())
    assert train.main(["--out", str(run), "--stage", "nbv", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "nbv starts from the end of stage 1: GDNet" in err[0]


def test_nbv_decision_always_moves(tiny_cfg):
    cfg = C.replace(tiny_cfg, **{"scene.max_objects": 3, "nbv.max_objects": 10})
    stage = VagsStage(cfg, "nbv")
    assert stage.stage.max_objects == 3 and stage.which == 2 and stage.nbv  # capped at the scene's
    state = SimpleNamespace(env=None, success=None, gd_grasp=jnp.zeros((2, 3), jnp.int32),
                            gd_qmax=jnp.array([1e6, -1e6]), calibration=jnp.zeros((3,)), threshold=jnp.inf)
    q_view = jnp.zeros((2, 4, 4))
    decision, p_direct, _ = stage._decision(state, q_view, state.gd_grasp, jnp.zeros((2, 2), jnp.int32),
                                            stage.flags.stage3)
    assert not np.asarray(decision.direct).any()  # even a huge GDNet Q moves
    assert np.asarray(p_direct).tolist() == [0.0, 0.0]  # no success net consulted
