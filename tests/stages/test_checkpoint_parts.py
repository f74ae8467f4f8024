"""``checkpoint.restore_parts``: several parts of one checkpoint in one read, the same arrays as
``restore_part`` per part; optional parts; a part of another shape refused before reading; a
restore compiles nothing."""
import numpy as np
import pytest

from vags_jax.compile_cache import CompileClock
from vags_jax.stages import checkpoint


def _tree(scale):
    return {"params": {"w": np.arange(6, dtype=np.float32).reshape(2, 3) * scale,
                       "b": np.full((3,), scale, np.float32)}}


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    d = str(tmp_path_factory.mktemp("ckpt"))
    checkpoint.save(d, 3, {"a": _tree(1.0), "b": _tree(2.0), "threshold": np.float32(0.5),
                           "calibration": np.array([0.1, 0.2], np.float32)})
    return d


def test_restore_parts_equals_restore_part_per_part(saved):
    like = _tree(0.0)
    got, step = checkpoint.restore_parts(saved, {"a": like, "b": like, "threshold": np.zeros((), np.float32)})
    assert step == 3
    for name in ("a", "b", "threshold"):
        one, _ = checkpoint.restore_part(saved, name, like if name != "threshold" else np.zeros((), np.float32))
        assert checkpoint.tree_equal(got[name], one), name
    assert np.array_equal(np.asarray(got["b"]["params"]["w"]), _tree(2.0)["params"]["w"])


def test_a_restore_compiles_no_program(tmp_path):
    """The arrays go to the device by transfer: no program per leaf shape to compile, or to load
    from the compile cache (each costs time in every eval.py and train.py process).  Shapes no
    other test uses, so that no program of theirs is already in this process."""
    tree = {"w": np.ones((5, 7, 11), np.float32), "n": np.arange(13, dtype=np.int32)}
    checkpoint.save(str(tmp_path), 1, {"odd": tree})
    with CompileClock() as clock:
        got, _ = checkpoint.restore_parts(str(tmp_path), {"odd": {k: np.zeros_like(v) for k, v in tree.items()}})
    assert checkpoint.tree_equal(got["odd"], tree)
    assert clock.backend == 0, clock.as_dict()


def test_optional_parts_and_parts_as_saved(saved):
    got, _ = checkpoint.restore_parts(saved, {"a": _tree(0.0), "success": _tree(0.0), "calibration": None},
                                      optional=("success", "calibration"))
    assert got["success"] is None
    assert np.array_equal(next(iter(got["calibration"].values())), np.array([0.1, 0.2], np.float32))
    with pytest.raises(checkpoint.CheckpointError, match="no part 'success'"):
        checkpoint.restore_parts(saved, {"a": _tree(0.0), "success": _tree(0.0)})


def test_a_part_of_another_shape_is_refused(saved):
    other = {"params": {"w": np.zeros((3, 3), np.float32), "b": np.zeros((3,), np.float32)}}
    with pytest.raises(checkpoint.CheckpointError):
        checkpoint.restore_parts(saved, {"a": other})
