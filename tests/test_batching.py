"""batching.map_in_groups: groups give what one call gives, padding included."""
import jax.numpy as jnp
import numpy as np

from vags_jax.batching import map_in_groups


def _fn(x, y):
    # Per-item work with two outputs: (x_i * 2 + sum(y_i), argmax of y_i).
    return x * 2 + y.sum(axis=1), jnp.argmax(y, axis=1)


def test_groups_equal_one_call_with_padding():
    x = jnp.arange(5, dtype=jnp.float32)                      # B = 5, groups of 2 -> one padded item
    y = jnp.array([[0, 1, 0], [3, 0, 0], [0, 0, 2], [1, 5, 1], [2, 2, 9]], jnp.float32)
    a, i = map_in_groups(_fn, (x, y), 2)
    # By hand: x*2 + row sums = [0+1, 2+3, 4+2, 6+7, 8+13]; argmax per row = [1, 0, 2, 1, 2].
    np.testing.assert_array_equal(np.asarray(a), [1, 5, 6, 13, 21])
    np.testing.assert_array_equal(np.asarray(i), [1, 0, 2, 1, 2])
    assert a.shape == (5,) and i.shape == (5,)


def test_group_zero_or_large_is_one_call():
    x, y = jnp.ones((3,)), jnp.eye(3)
    for group in (0, 3, 10):
        a, i = map_in_groups(_fn, (x, y), group)
        np.testing.assert_array_equal(np.asarray(a), [3, 3, 3])
        np.testing.assert_array_equal(np.asarray(i), [0, 1, 2])
