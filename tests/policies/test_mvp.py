"""MVP (``vags_jax.policies.mvp_grid`` / ``mvp``): the grid's statistics on hand-made histograms
with hand-computed values, the greedy descending step, and on the tiny scene the camera always
going down, stopping above ``mvp.stop_height`` and every move counted as a motion."""
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from vags_jax import config as C
from vags_jax.policies import mvp_grid as G

WS = C.Workspace(size=0.05, heightmap_px=8)  # a 5 x 5 grid of 1 cm cells
MVP = C.Mvp(cell=0.01, quality_bins=2, angle_bins=4, start_height=0.5, stop_height=0.25, step=0.05,
            min_descent=0.6, greedy_window=0.1, best_scale=0.15, best_gain=0.75, failure_sigma=0.01)


def _grid(qhist, count=None, avote=None, zsum=None):
    qhist = jnp.asarray(qhist, jnp.float32)
    n = qhist.shape[1]
    count = jnp.ones(qhist.shape[:3]) if count is None else jnp.asarray(count, jnp.float32)
    avote = jnp.zeros(qhist.shape[:3] + (4,)) if avote is None else jnp.asarray(avote, jnp.float32)
    zsum = jnp.zeros(qhist.shape[:3]) if zsum is None else jnp.asarray(zsum, jnp.float32)
    assert qhist.shape[2] == n
    return G.ViewGrid(qhist=qhist, avote=avote, count=count, zsum=zsum)


def test_grid_size_and_cells():
    assert G.grid_size(WS, MVP) == 5
    assert G.grid_size(C.Workspace(), C.Mvp()) == 90  # 0.448 m at 5 mm (MVP's cells)
    c = np.asarray(G.cell_centres(WS, 5))
    np.testing.assert_allclose(c[0, 0], [-0.02, -0.02], atol=1e-7)
    np.testing.assert_allclose(c[1, 3], [0.01, -0.01], atol=1e-7)  # row along +y, column along +x
    rc, inside = G.world_to_cell(jnp.array([[0.011, -0.012], [0.03, 0.0]]), WS, 5)
    assert rc.tolist() == [[1, 3], [2, 4]] and inside.tolist() == [True, False]


def test_entropy_of_hand_made_histograms():
    h = jnp.array([[1.0, 1.0], [3.0, 1.0], [5.0, 0.0 + 1e-30]])
    np.testing.assert_allclose(np.asarray(G.entropy(h)),
                               [math.log(2), -(0.75 * math.log(0.75) + 0.25 * math.log(0.25)), 0.0], atol=1e-6)


def test_add_observations_counts_bins_votes_and_heights():
    g = G.init_grid(1, 5, MVP)  # every quality bin starts at 1
    xyz = jnp.array([[[0.001, 0.001, 0.04], [0.002, -0.001, 0.06], [0.011, 0.001, 0.02], [0.5, 0.0, 0.1]]])
    q = jnp.array([[0.9, 0.2, 0.7, 1.0]])
    yaw = jnp.array([[0.1, 1.2, -1.2, 0.0]])
    valid = jnp.array([[True, True, True, True]])  # the 4th falls outside the grid
    g = G.add_observations(g, xyz, q, yaw, valid, WS)
    np.testing.assert_allclose(np.asarray(g.qhist[0, 2, 2]), [2.0, 2.0])  # one low, one high, + prior 1 each
    np.testing.assert_allclose(np.asarray(g.qhist[0, 2, 3]), [1.0, 2.0])
    assert float(g.count.sum()) == 3.0 and float(g.count[0, 2, 2]) == 2.0
    np.testing.assert_allclose(float(g.zsum[0, 2, 2]), 0.10, atol=1e-6)
    # angle bins of 45 deg from -90: yaw 0.1 -> bin 2 (vote 0.75, its quality bin's centre), 1.2 -> bin 3 (0.25)
    np.testing.assert_allclose(np.asarray(g.avote[0, 2, 2]), [0.0, 0.0, 0.75, 0.25])
    np.testing.assert_allclose(np.asarray(g.avote[0, 2, 3]), [0.75, 0.0, 0.0, 0.0])


def test_mean_quality_best_grasp_and_failures():
    qh = np.ones((1, 5, 5, 2), np.float32)
    qh[0, 2, 2] = [1.0, 3.0]  # mean (0.25 + 3 * 0.75) / 4 = 0.625
    qh[0, 2, 3] = [3.0, 1.0]  # 0.375
    qh[0, 0, 0] = [0.0 + 1e-6, 9.0]  # on the border: ignored
    count = np.zeros((1, 5, 5), np.float32)
    count[0, 2, 2] = count[0, 2, 3] = count[0, 0, 0] = 4.0
    av = np.zeros((1, 5, 5, 4), np.float32)
    av[0, 2, 2, 2] = 1.0  # angle bin 2: centre -pi/2 + 2.5 * pi/4 = pi/8
    g = _grid(qh, count, av, zsum=count * 0.05)
    m = np.asarray(G.mean_quality(g, jnp.zeros((1, 5, 5))))
    assert m[0, 2, 2] == pytest.approx(0.625) and m[0, 2, 3] == pytest.approx(0.375)
    assert m[0, 0, 0] == 0.0 and m[0, 1, 1] == 0.0  # border; never seen
    xy, z, yaw, score = G.best_grasp(g, jnp.zeros((1, 5, 5)), WS)
    # the score-weighted mean of the neighbours' centres: (0.625 * x(2,2) + 0.375 * x(2,3)) / 1.0
    np.testing.assert_allclose(np.asarray(xy[0]), [0.375 * 0.01, 0.0], atol=1e-7)
    assert float(z[0]) == pytest.approx(0.05) and float(score[0]) == pytest.approx(0.625)
    assert float(yaw[0]) == pytest.approx(math.pi / 8, abs=1e-6)
    fail = G.add_failure(jnp.zeros((1, 5, 5)), jnp.array([[0.0, 0.0]]), jnp.array([True]), WS, 0.01)
    assert float(fail[0, 2, 2]) == pytest.approx(1.0) and float(fail[0, 2, 3]) == pytest.approx(math.exp(-0.5))
    assert float(G.add_failure(jnp.zeros((1, 5, 5)), jnp.zeros((1, 2)), jnp.array([False]), WS, 0.01).sum()) == 0
    # the failure suppresses (2, 2): 0.625 - 1 -> 0; (2, 3) 0.375 - e^-0.5 -> 0 as well; nothing left but zeros
    assert float(G.mean_quality(g, fail).max()) == 0.0


def test_footprint_blur_on_an_impulse():
    x = jnp.zeros((1, 9, 9)).at[0, 4, 4].set(1.0)
    out = np.asarray(G.blur(x, jnp.array([1.0])))[0]
    z = sum(math.exp(-0.5 * d * d) for d in range(-3, 4))  # the kernel truncated at 3 sigma
    assert out[4, 4] == pytest.approx(1 / z ** 2, rel=1e-5)
    assert out[4, 5] == pytest.approx(math.exp(-0.5) / z ** 2, rel=1e-5)
    assert out[4, 8] == 0.0 and out.sum() == pytest.approx(1.0, rel=1e-5)
    # MVP's sigma: the footprint in cells / 6 (0.4 m up, 0.75 m wide per metre, 5 mm cells: 10 cells)
    assert float(G.footprint_sigma(jnp.array([0.4]), 0.75, 0.005)[0]) == pytest.approx(10.0)


def test_travel_cost_grows_as_the_camera_descends():
    centres = G.cell_centres(WS, 5)
    best = jnp.array([[0.0, 0.0]])
    top = np.asarray(G.travel_cost(centres, best, jnp.array([0.5]), MVP))
    assert np.abs(top).max() == 0.0  # h = 1 at the start height: no pull
    low = np.asarray(G.travel_cost(centres, best, jnp.array([0.25]), MVP))  # h = 0
    assert low[0, 2, 4] == pytest.approx(0.02 / 0.15 * 0.75)
    mid = np.asarray(G.travel_cost(centres, best, jnp.array([0.375]), MVP))  # h = 0.5
    assert mid[0, 2, 4] == pytest.approx(0.5 * low[0, 2, 4])


def test_next_position_moves_to_the_best_cell_in_the_window_and_always_down():
    centres = G.cell_centres(WS, 5)
    value = jnp.zeros((2, 5, 5)).at[0, 2, 4].set(1.0).at[1, 0, 0].set(1.0)
    pos = jnp.array([[0.0, 0.0, 0.5], [0.0, 0.0, 0.3]])
    nxt = np.asarray(G.next_position(value, centres, pos, MVP, WS))
    # world 0: target 2 cm along +x -> lateral 0.02 / 0.1 = 0.2, down sqrt(1 - 0.04)
    np.testing.assert_allclose(nxt[0], [0.05 * 0.2, 0.0, 0.5 - 0.05 * math.sqrt(0.96)], atol=1e-6)
    step = nxt - np.asarray(pos)
    assert (step[:, 2] <= -MVP.step * MVP.min_descent + 1e-7).all()  # always down, at least 3 cm
    far = jnp.zeros((1, 5, 5)).at[0, 0, 0].set(1.0)
    w = C.Mvp(**{**MVP.__dict__, "greedy_window": 0.01})  # the best cell is 2.8 cm away: out of the window
    nxt = np.asarray(G.next_position(far, centres, jnp.array([[0.0, 0.0, 0.4]]), w, WS))
    np.testing.assert_allclose(nxt[0], [0.0, 0.0, 0.35], atol=1e-7)  # stays over its own cell, straight down


def test_view_steps_fit_the_descent():
    m = C.Mvp()
    assert m.view_steps() == 1 + 8  # (0.50 - 0.25) / (0.05 * 0.6) = 8.3 descents after the start pose
    with pytest.raises(ValueError, match="stop_height < start_height"):
        C.Mvp(start_height=0.2, stop_height=0.25)


@pytest.fixture(scope="module")
def mvp_world(tiny_cfg, programs):
    from vags_jax.nets.ggcnn import init_ggcnn
    from vags_jax.policies.mvp import MvpPlanner

    cfg = C.replace(tiny_cfg, **{"mvp.cell": 0.02})
    env = programs.env(cfg)  # its reset is the program other tests of the tiny scene compile
    state = env.reset(jax.random.PRNGKey(3), np.array([2, 1]))
    params = init_ggcnn(jax.random.PRNGKey(0), size=cfg.ggcnn.input_size)
    return cfg, env, state, params, MvpPlanner(cfg)


def test_mvp_camera_descends_stops_above_the_limit_and_counts_every_move(mvp_world):
    cfg, env, state, params, mvp = mvp_world
    failures = mvp.init_memory(2)
    def views(p, k, s, f):
        walk, path = mvp.views(p, k, env, s, f)
        return walk.position, path, mvp.attempt(walk, f)

    position, path, attempt = jax.jit(views)(params, jax.random.PRNGKey(1), state, failures)
    z = np.asarray(path.position[..., 2]) - cfg.workspace.table_z  # (T, B)
    taken = np.asarray(path.taken)
    m = cfg.mvp
    for b in range(2):
        zs = z[taken[:, b], b]
        assert zs[0] == pytest.approx(m.start_height)
        assert (np.diff(zs) <= -m.step * m.min_descent + 1e-6).all()  # every step goes down
        assert (zs >= m.stop_height - 1e-6).all()
        assert zs[-1] - m.step < m.stop_height  # the next step would have gone below the limit
        assert not taken[taken[:, b].sum():, b].any()  # once stopped, it stays stopped
        assert int(attempt.motions[b]) == 1 + taken[:, b].sum()  # the grasp + every camera move
    np.testing.assert_allclose(np.asarray(attempt.start), np.asarray(position))
    assert (np.asarray(attempt.view_travel) > m.start_height - m.stop_height).all()
    # the failure map: a failed attempt's position is remembered, a success's is not
    mem = np.asarray(mvp.remember(failures, attempt, jnp.array([False, True])))
    xy = np.asarray(attempt.position[0, :2])
    centres = np.asarray(G.cell_centres(cfg.workspace, mvp.n))
    want = np.exp(-0.5 * ((centres - xy) ** 2).sum(-1) / m.failure_sigma ** 2)
    np.testing.assert_allclose(mem[0], want, rtol=1e-4, atol=1e-7)
    assert mem[0].max() > 0 and mem[1].max() == 0.0
