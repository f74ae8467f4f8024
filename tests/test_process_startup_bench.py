"""bench/process_startup.py: the import-time table read from hand-made ``-X importtime`` text,
and small programs compiled in one child process and loaded from the cache in the next."""
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "bench"))
import process_startup  # noqa: E402

IMPORTTIME = """import time: self [us] | cumulative | imported package
import time:       100 |        100 |   os
import time:      2000 |     900000 |       jax._src.core
import time:      1000 |    1500000 |     jax
import time:       500 |    2600000 |     mujoco.mjx
import time:       300 |     300000 |       warp
import time:      4000 |    4500000 |   vags_jax.benchmark.compare
import time:       700 |    5000000 | eval
"""


def test_importtime_levels_and_packages():
    assert process_startup.importtime_top(IMPORTTIME, 5, level=0) == [{"module": "eval", "seconds": 5.0}]
    assert process_startup.importtime_top(IMPORTTIME, 5) == [
        {"module": "vags_jax.benchmark.compare", "seconds": 4.5}, {"module": "os", "seconds": 0.0001}]
    assert process_startup.importtime_top(IMPORTTIME, 2, level=2) == [
        {"module": "mujoco.mjx", "seconds": 2.6}, {"module": "jax", "seconds": 1.5}]
    # a package's outermost import, what it pulled in included; eval itself is no package
    assert process_startup.package_seconds(IMPORTTIME) == {"vags_jax": 4.5, "mujoco": 2.6, "jax": 1.5, "warp": 0.3}


def test_small_programs_compile_then_load(tmp_path):
    """The first child compiles every program (and no other), the second loads them all."""
    got = process_startup.programs(3, str(tmp_path))
    assert (got["first"]["compiled"], got["first"]["loaded"]) == (3, 0), got
    assert (got["second"]["compiled"], got["second"]["loaded"]) == (0, 3), got
    assert got["load_ms_per_program"] > 0 and got["compile_ms_per_program"] > 0
