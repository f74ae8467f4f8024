"""What plans a VAGS evaluation's grasps, in words for eval.py's log and as a record for its
report, and the note for an ablation whose direct grasp is planned by another score than VAGS's
grasps after a move (their difference then mixes the planner with the viewpoint)."""
from __future__ import annotations

from typing import Optional

from vags_jax.config import Config

_DIRECT = {"q": "GDNet's argmax", "q_mean": "GDNet's argmax of its half-turn mean",
           "success": "the success net's argmax (its half-turn mean)"}
_AFTER_MOVE = {"q": "GDNet's argmax on the maps fused with the close view",
               "success": "the success net's argmax on the maps fused with the close view",
               "ggcnn": "GG-CNN's best grasp in the close depth image"}


def planners(cfg: Config) -> dict:
    """{"direct": vags.direct_score, "after_move": vags.close_score, or "ggcnn" where GG-CNN
    plans the grasp after a move (vags.local_planner)}: the report's ``planners``."""
    v = cfg.vags
    return {"direct": v.direct_score, "after_move": "ggcnn" if v.local_planner == "ggcnn" else v.close_score}


def describe(cfg: Config, no_viewpoint: bool) -> str:
    """One log line: what plans the direct grasps and, unless the camera never moves, the grasps
    after a move, each with the setting that chose it."""
    p = planners(cfg)
    line = f"direct grasps planned by {_DIRECT[p['direct']]} (vags.direct_score={p['direct']!r})"
    if no_viewpoint:
        return line + "; the camera never moves"
    setting = "vags.local_planner='ggcnn'" if p["after_move"] == "ggcnn" else f"vags.close_score={p['after_move']!r}"
    return line + f"; grasps after a move by {_AFTER_MOVE[p['after_move']]} ({setting})"


def ablation_note(cfg: Config) -> Optional[str]:
    """For ``--no-viewpoint``: a note where VAGS on the same config would grasp after a move by
    another score than this ablation grasps directly, so that VAGS's margin over it mixes the
    planner with the viewpoint; None where both use one score, or where GG-CNN plans after a
    move (the paper's design)."""
    v = cfg.vags
    if v.local_planner != "gdnet" or v.close_score == v.direct_score:
        return None
    return (f"note: VAGS with this config grasps after a move by vags.close_score={v.close_score!r}, this ablation "
            f"directly by vags.direct_score={v.direct_score!r}, so VAGS's margin over it mixes the planner with the "
            f"viewpoint. --set vags.direct_score={v.close_score} on both plans them by one score (under the rate "
            f"gate VAGS then needs a table measured with python -m vags_jax.stages.gate_measure --run RUN "
            f"--direct-score {v.close_score}); docs/method.md, \"What plans the direct grasp\"")


def pick_note(cfg: Config, table_direct_score: Optional[str], gdnet_source: str) -> Optional[str]:
    """For ``--no-viewpoint`` on a run whose gate table picked its GDNet
    (``vags.stage3_gdnet_pick="rate"``; ``table_direct_score`` None where no table was loaded):
    a note where that table was measured with another ``vags.direct_score`` than this ablation
    plans with.  VAGS under this config plays the GDNet of a table measured with its own score,
    which may be the other stage's, and then this is not VAGS's own ablation; None otherwise."""
    now = cfg.vags.direct_score
    if cfg.vags.stage3_gdnet_pick != "rate" or table_direct_score is None or table_direct_score == now:
        return None
    return (f"note: this ablation plays GDNet {gdnet_source}, picked by RUN/gate.json, which was measured with "
            f"vags.direct_score={table_direct_score!r}. VAGS with vags.direct_score={now!r} needs a table measured "
            f"with it (python -m vags_jax.stages.gate_measure --run RUN --direct-score {now}), which may pick the "
            f"other stage's GDNet: evaluate this ablation on the run with that table, so that both play one GDNet")
