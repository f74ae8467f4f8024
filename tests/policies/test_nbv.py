"""The NBV baseline's policy (``catalog.nbv_plan``): on the tiny scene it always moves the camera to
its network's argmax viewpoint and grasps from there (2 motions), whatever the network says."""
import jax
import jax.numpy as jnp
import numpy as np

from vags_jax.nets import init_qnet, make_qnet, nbv_net
from vags_jax.perception import camera
from vags_jax.policies import catalog as P
from vags_jax.policies.decision import greedy
from vags_jax.stages.rundir import VagsNetworks


def test_nbv_always_moves_to_its_best_viewpoint(tiny_cfg, programs):
    cfg = tiny_cfg
    env = programs.env(cfg)
    state = env.reset(jax.random.PRNGKey(3), np.array([2, 1]))
    H = cfg.workspace.heightmap_px
    view_net = make_qnet(nbv_net(cfg.net), "vanet")
    va = init_qnet(jax.random.PRNGKey(1), view_net, H, H)
    gd = init_qnet(jax.random.PRNGKey(2), make_qnet(cfg.net, "gdnet"), H, H)
    nets = VagsNetworks(gdnet=gd, vanet=va, ggcnn=None, q_threshold=jnp.asarray(jnp.inf))
    policy = P.make_policy("nbv", cfg, vags_networks=nets)  # the default close-view planner: GDNet's
    attempt, q_view = jax.jit(lambda p, k, s: (policy.plan(p, k, env, s), view_net.apply(p["vanet"], s.color,
                                                                                      s.height)))(
        policy.params, jax.random.PRNGKey(0), state)
    assert np.asarray(attempt.motions).tolist() == [2, 2]  # a move to the viewpoint, then the grasp
    assert (np.asarray(attempt.view_travel) > 0).all()
    view, _ = greedy(q_view)
    want = camera.viewpoint_pose(view, state.height, cfg.workspace, cfg.camera)[:, :3, 3]
    np.testing.assert_allclose(np.asarray(attempt.start), np.asarray(want), atol=1e-6)  # the grasp starts there
