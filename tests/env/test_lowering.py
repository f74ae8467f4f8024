"""Programs lower to the same text whatever the process traced before (``vags_jax.lowering``), so
the persistent compile cache serves a second environment of one config.  Lowering only."""
import jax
import numpy as np

from vags_jax import lowering
from vags_jax.env import VagsEnv


def _programs(env):
    """StableHLO text of the env's jitted reset and grasp for 2 worlds."""
    env.prepare(2)
    key, n = jax.random.PRNGKey(0), np.array([1, 2], np.int32)
    state = jax.eval_shape(env.step_reset, key, n)
    pixel, rotation = np.zeros((2, 2), np.int32), np.zeros((2,), np.int32)
    return (env._reset_worlds_jit.lower(jax.random.split(key, 2), n, key).as_text(),
            env._grasp_jit.lower(state, pixel, rotation, key).as_text())


def test_two_environments_of_one_config_lower_to_the_same_text(tiny_cfg):
    # Without the pinned caches the second reset had two more @remainder functions (MJX's
    # jnp.take(mode="wrap") under vmap: an evicted inner cache entry rebuilt as a new object).
    first = _programs(VagsEnv(tiny_cfg))
    second = _programs(VagsEnv(tiny_cfg))
    for name, a, b in zip(("step_reset", "step_grasp"), first, second):
        same = a == b  # not asserted directly: pytest would print a diff of 2 MB texts
        assert same, (f"{name} of a second VagsEnv lowers to other text: {b.count('func.func')} "
                      f"functions against {a.count('func.func')}")


def test_importing_vags_jax_pins_every_listed_jax_cache():
    # A JAX upgrade that renames one of them shows up here.
    missing = [f"{m.__name__}.{name}" for m, name in lowering._JAXPR_CACHES
               if not getattr(m, lowering._PINNED + name, False)]
    assert not missing
