"""eval.py's account of what plans a VAGS evaluation's grasps (``benchmark.planners``), and the
note that an ablation's direct grasp is planned by another score than VAGS's grasps after a move."""
import itertools

import pytest

from vags_jax import config as C
from vags_jax.benchmark import planners


def _cfg(**vags):
    return C.replace(C.gpu(), **{f"vags.{k}": v for k, v in vags.items()})


def test_the_gpu_preset_plans_its_direct_grasp_and_its_grasp_after_a_move_by_different_scores():
    cfg = C.gpu()
    assert planners.planners(cfg) == {"direct": "q", "after_move": "success"}
    line = planners.describe(cfg, no_viewpoint=False)
    assert "GDNet's argmax (vags.direct_score='q')" in line and "vags.close_score='success'" in line
    assert planners.describe(cfg, no_viewpoint=True).endswith("the camera never moves")
    note = planners.ablation_note(cfg)
    assert note is not None and "--set vags.direct_score=success" in note and "--direct-score success" in note


@pytest.mark.parametrize("vags", [dict(direct_score="success"), dict(close_score="q"),
                                  dict(local_planner="ggcnn", close_score="q")])
def test_no_note_where_one_score_plans_both_or_ggcnn_plans_after_a_move(vags):
    assert planners.ablation_note(_cfg(**vags)) is None


def test_ggcnn_after_a_move_is_named():
    cfg = _cfg(local_planner="ggcnn", close_score="q")
    assert planners.planners(cfg)["after_move"] == "ggcnn"
    assert "GG-CNN" in planners.describe(cfg, no_viewpoint=False)


@pytest.mark.parametrize("direct,close", list(itertools.product(C.sections.VAGS_DIRECT_SCORES,
                                                                 C.sections.VAGS_CLOSE_SCORES)))
def test_every_setting_is_described(direct, close):
    line = planners.describe(_cfg(direct_score=direct, close_score=close), no_viewpoint=False)
    assert f"vags.direct_score={direct!r}" in line and f"vags.close_score={close!r}" in line


def test_pick_note_where_the_gdnet_was_picked_by_a_table_of_another_direct_score():
    cfg = _cfg(direct_score="q_mean")
    note = planners.pick_note(cfg, "q", "stage2 step 80")
    assert note is not None and "GDNet stage2 step 80" in note and "vags.direct_score='q'" in note
    assert "--direct-score q_mean" in note
    assert planners.pick_note(cfg, "q_mean", "stage2 step 80") is None  # the table's own score
    assert planners.pick_note(cfg, None, "stage3 step 80") is None  # no table: stage 3's GDNet, no pick
    assert planners.pick_note(C.replace(cfg, **{"vags.stage3_gdnet_pick": "last"}), "q", "stage3 step 80") is None
