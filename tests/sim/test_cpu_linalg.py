"""Once ``vags_jax.sim`` is imported, the CPU's Cholesky factorisations and triangular solves over
more than ``LAPACK_MAX_BATCH`` matrices lower to XLA's own algorithms (``vags_jax/sim/cpu_linalg.py``):
jaxlib 0.10's LAPACK kernels deadlocked MJX's two concurrent factorisations of a step on a 2-core
machine (``eval.py`` of 150 worlds never ended)."""
import jax
import jax.numpy as jnp
import jax.scipy.linalg as sla
import mujoco
import numpy as np
from mujoco import mjx

import vags_jax.sim  # noqa: F401  (applies the lowering)
from vags_jax.sim import cpu_linalg

# A hinge with joint damping (MJX's Euler integrator then factorises M + h D beside factor_m's M,
# as in the scene's gripper) and a free box on a plane.
XML = """
<mujoco>
  <worldbody>
    <geom type="plane" size="1 1 0.1"/>
    <body pos="0 0 0.5"><joint type="hinge" axis="0 1 0" damping="0.5"/><geom type="capsule" size="0.02 0.1"/></body>
    <body pos="0.3 0 0.1"><freejoint/><geom type="box" size="0.03 0.03 0.03"/></body>
  </worldbody>
</mujoco>
"""


def _spd(batch: int, n: int, seed: int = 0) -> np.ndarray:
    a = np.random.RandomState(seed).randn(batch, n, n).astype(np.float32)
    return a @ a.transpose(0, 2, 1) + n * np.eye(n, dtype=np.float32)


def _cho_solve_text(batch: int) -> str:
    s, b = _spd(batch, 6), np.ones((batch, 6), np.float32)
    return jax.jit(jax.vmap(lambda s, b: sla.cho_solve(sla.cho_factor(s), b))).lower(s, b).as_text()


def test_large_batches_lower_to_hlo_ops_small_ones_keep_lapack():
    assert cpu_linalg.applied() and cpu_linalg.use_xla_linalg_on_cpu()  # idempotent
    big = _cho_solve_text(cpu_linalg.LAPACK_MAX_BATCH + 1)
    assert "cholesky" in big and "triangular_solve" in big and "lapack" not in big
    small = _cho_solve_text(cpu_linalg.LAPACK_MAX_BATCH)
    assert "lapack_spotrf" in small and "lapack_strsm" in small


def test_factorisations_and_solves_equal_numpys():
    s = _spd(cpu_linalg.LAPACK_MAX_BATCH + 4, 24)
    np.testing.assert_allclose(np.asarray(jax.jit(jnp.linalg.cholesky)(s)), np.linalg.cholesky(s),
                               rtol=1e-4, atol=1e-4)
    b = np.random.RandomState(1).randn(len(s), 24).astype(np.float32)
    x = jax.jit(jax.vmap(lambda s, b: sla.cho_solve(sla.cho_factor(s), b)))(s, b)  # as MJX solves
    np.testing.assert_allclose(np.asarray(x), np.linalg.solve(s, b[..., None])[..., 0], rtol=1e-4, atol=1e-5)
    not_spd = np.broadcast_to(np.array([[1.0, 2.0], [2.0, 1.0]], np.float32), (len(s), 2, 2))
    assert np.isnan(np.asarray(jnp.linalg.cholesky(not_spd))).any(axis=(1, 2)).all()  # every matrix


def test_a_batched_mjx_step_of_many_worlds_makes_no_lapack_call():
    model = mjx.put_model(mujoco.MjModel.from_xml_string(XML))
    data = jax.vmap(lambda _: mjx.make_data(model))(jnp.arange(64))  # 64: LAPACK's kernels hung there
    text = jax.jit(jax.vmap(lambda d: mjx.step(model, d))).lower(data).as_text()
    assert text.count("cholesky") >= 2 and "custom_call" not in text  # no LAPACK kernel at all
