"""Config: grasp-phase settings are validated with messages that name the field."""
import pytest

from vags_jax import config as C


def test_descent_clearance_accepts_none_and_metres():
    assert C.replace(C.Config(), **C.parse_overrides(["grasp.descent_clearance=null"])).grasp.descent_clearance is None
    assert C.replace(C.Config(), **{"grasp.descent_clearance": 0.05}).grasp.descent_clearance == 0.05


@pytest.mark.parametrize("bad", [0.0, -0.01, 0.2, "none", True])
def test_descent_clearance_rejects_bad_values(bad):
    with pytest.raises(ValueError, match=r"Grasp\.descent_clearance.*null/None.*0\.005"):
        C.replace(C.Config(), **{"grasp.descent_clearance": bad})

