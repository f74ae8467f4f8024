"""``vags.direct_score``: what plans the direct grasp from the global view (GDNet's argmax, or the
success net's half-turn mean), on hand-made maps, and the errors that say how to evaluate a run
whose table was measured with the other planner."""
from types import SimpleNamespace

import jax.numpy as jnp
import numpy as np
import pytest

from vags_jax import config as C
from vags_jax.policies import rate_gate
from vags_jax.policies.catalog import vags_params
from vags_jax.policies.decision import VagsNets, decide, direct_grasp, direct_value


def _maps():
    """GDNet's map peaks at rotation 0, cell (5, 5).  The success net's: 0.9 at rotation 1, cell
    (2, 2) but 0.0 at its half turn (mean 0.45); 0.6 at rotations 1 and 3 of cell (6, 1) (mean
    0.6, the half-turn mean's argmax)."""
    g = np.zeros((1, 4, 8, 8), np.float32)
    g[0, 0, 5, 5] = 5.0
    s = np.zeros((1, 4, 8, 8), np.float32)
    s[0, 1, 2, 2] = 0.9
    s[0, 1, 6, 1] = s[0, 3, 6, 1] = 0.6
    return jnp.asarray(g), jnp.asarray(s)


def test_the_direct_grasp_is_the_configured_planners_argmax():
    q, s = _maps()
    grasp, q_max = direct_grasp(q, s, "q")
    assert np.asarray(grasp)[0].tolist() == [0, 5, 5] and float(q_max[0]) == 5.0
    grasp, q_max = direct_grasp(q, s, "success")
    assert np.asarray(grasp)[0].tolist() == [1, 6, 1]  # not the raw peak (2, 2), which its half turn rates 0
    assert float(q_max[0]) == 5.0  # the "q" gate still reads GDNet's largest Q
    view = jnp.zeros((1, 8, 8), jnp.float32).at[0, 3, 4].set(1.0)
    d = decide(q, view, 0.0, s, "q", viewpoint="grasp", direct_score="success")
    assert np.asarray(d.grasp)[0].tolist() == [1, 6, 1] and np.asarray(d.view)[0].tolist() == [6, 1]
    d = decide(q, view, 0.0, s, "q")
    assert np.asarray(d.grasp)[0].tolist() == [0, 5, 5] and np.asarray(d.view)[0].tolist() == [3, 4]
    # The rate gate's p_direct is the success net's estimate of the grasp the planner chose.
    # Bins of p_direct below and above 0.5: a move pays in the lower one only.
    table = jnp.array([[0.5, jnp.inf], [1.0, -1.0]], jnp.float32)
    assert bool(decide(q, view, 0.0, s, "rate", gate_table=table, direct_score="success").direct[0])  # p 0.6
    assert not bool(decide(q, view, 0.0, s, "rate", gate_table=table).direct[0])  # p 0.0 at GDNet's grasp
    # Over half a turn (grasp.half_turn) rotation 3 is not rotation 1 turned: the raw peak wins,
    # and the rate gate's p_direct there is the success net's own value (0.9: a move pays not).
    assert np.asarray(direct_grasp(q, s, "success", half_turn=True)[0])[0].tolist() == [1, 2, 2]
    assert bool(decide(q, view, 0.0, s, "rate", gate_table=table, gate_estimate="symmetric", direct_score="success",
                       half_turn=True).direct[0])
    with pytest.raises(ValueError, match="direct_score=success plans the direct grasp with the success net"):
        direct_grasp(q, None, "success")
    with pytest.raises(ValueError, match="use vags.direct_score=q"):
        direct_grasp(q[:, :3], s[:, :3], "success")
    with pytest.raises(ValueError, match="unknown direct score"):
        direct_grasp(q, s, "ggcnn")


def test_the_q_mean_direct_grasp_is_the_argmax_of_gdnets_two_views_of_each_grasp():
    """GDNet's map: 5.0 at rotation 0 of cell (5, 5) with 0.0 at its half turn (rotation 2 of 4:
    mean 2.5); 3.0 at rotations 1 and 3 of cell (6, 1) (mean 3.0).  The plain argmax takes the
    single larger view, the half-turn mean the grasp both views rate."""
    g = np.zeros((1, 4, 8, 8), np.float32)
    g[0, 0, 5, 5] = 5.0
    g[0, 1, 6, 1] = g[0, 3, 6, 1] = 3.0
    q = jnp.asarray(g)
    assert np.asarray(direct_grasp(q, None, "q")[0])[0].tolist() == [0, 5, 5]
    grasp, q_max = direct_grasp(q, None, "q_mean")  # no success net needed
    assert np.asarray(grasp)[0].tolist() == [1, 6, 1]
    assert float(q_max[0]) == 5.0  # the "q" gate still reads GDNet's largest Q
    d = decide(q, jnp.zeros((1, 8, 8), jnp.float32), 0.0, None, "q", viewpoint="grasp", direct_score="q_mean")
    assert np.asarray(d.grasp)[0].tolist() == [1, 6, 1] and np.asarray(d.view)[0].tolist() == [6, 1]
    # Over half a turn each grasp has one view: the plain argmax.
    assert np.asarray(direct_grasp(q, None, "q_mean", half_turn=True)[0])[0].tolist() == [0, 5, 5]
    with pytest.raises(ValueError, match="use vags.direct_score=q"):
        direct_grasp(q[:, :3], None, "q_mean")
    # The value each planner maximized at its grasp (predict's "direct_value").
    assert float(direct_value(q, None, grasp, "q_mean")[0]) == 3.0
    assert float(direct_value(q, None, jnp.asarray([[0, 5, 5]]), "q")[0]) == 5.0
    assert float(direct_value(q, None, jnp.asarray([[0, 5, 5]]), "q_mean")[0]) == 2.5  # (5 + 0) / 2
    _, s = _maps()
    assert float(direct_value(q, s, jnp.asarray([[1, 6, 1]]), "success")[0]) == pytest.approx(0.6)
    assert float(direct_value(q, s, jnp.asarray([[1, 2, 2]]), "success")[0]) == pytest.approx(0.45)  # (0.9 + 0) / 2
    cfg = C.replace(C.preset("tiny"), **{"vags.direct_score": "q_mean"})
    assert cfg.vags.direct_score == "q_mean"
    nets = VagsNets(C.replace(cfg, **{"vags.gate": "q"}))
    nets.q_fn = lambda net, variables: (lambda c, h: jnp.zeros((1, 4, 8, 8)))
    assert nets.q_maps({"gdnet": "g", "vanet": "v"}, None, None)[2] is None  # the success net is not run


def test_the_success_net_runs_for_a_success_planned_direct_grasp_under_any_gate():
    cfg = C.replace(C.preset("tiny"), **{"vags.gate": "q", "vags.direct_score": "success"})
    nets = VagsNets(cfg)
    calls = []
    nets.q_fn = lambda net, variables: (lambda c, h: calls.append(variables) or jnp.zeros((1, 4, 8, 8)))
    *_, q_success = nets.q_maps({"gdnet": "g", "vanet": "v", "success": "s"}, None, None)
    assert q_success is not None and calls == ["g", "v", "s"]
    nets = VagsNets(C.replace(cfg, **{"vags.direct_score": "q"}))
    nets.q_fn = lambda net, variables: (lambda c, h: calls.append(variables) or jnp.zeros((1, 4, 8, 8)))
    assert nets.q_maps({"gdnet": "g", "vanet": "v"}, None, None)[2] is None


def _networks(**kw):
    base = dict(success=(), ggcnn=None, q_threshold=np.float32(0.0), gdnet=None, vanet=None, calibration=None,
                gate_table=np.zeros((2, 1), np.float32), source="stage3 step 8", gate_estimate="grasp",
                gate_close_score="q", gate_direct_score="q")
    return SimpleNamespace(**{**base, **kw})


def test_direct_score_settings_that_cannot_work_say_what_to_fix(tmp_path):
    with pytest.raises(ValueError, match="vags.direct_score must be one of"):
        C.replace(C.Config(), **{"vags.direct_score": "ggcnn"})
    cfg = C.replace(C.Config(), **{"vags.gate": "rate", "vags.direct_score": "success"})
    with pytest.raises(ValueError, match="--set vags.direct_score=q, or measure .* --direct-score success"):
        vags_params(_networks(), cfg)
    assert "success" in vags_params(_networks(gate_direct_score="success"), cfg)
    assert "gdnet" in vags_params(_networks(), cfg, threshold=-np.inf)  # the ablation never moves: no table read
    with pytest.raises(ValueError, match="have none: evaluate with --set vags.direct_score=q"):
        vags_params(_networks(success=None), C.replace(cfg, **{"vags.gate": "q"}))
    # A table records its planner; one from before the field reads "q".
    run = str(tmp_path)
    assert rate_gate.direct_score_of(run) == "q"  # no table at all
    rate_gate.save(run, rate_gate.GateTable(edges=(), direct=(0.5,), moved=(0.6,), extra_seconds=(1.0,),
                                            move_value=(0.1,), states=(4,), rate=0.1), {"direct_score": "success"})
    assert rate_gate.direct_score_of(run) == "success"
