"""bench/predict_latency.py: which renderer draws its input frame."""
import os
import sys

import jax

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "bench"))
import predict_latency  # noqa: E402

from vags_jax import config as C  # noqa: E402


def test_a_warp_run_off_a_gpu_has_its_frame_drawn_by_the_ray_caster():
    warp_run = C.replace(C.preset("tiny"), **{"camera.renderer": "warp"})
    on_gpu = jax.default_backend() == "gpu"
    assert predict_latency.frame_renderer(warp_run) == ("warp" if on_gpu else "jax")
    assert predict_latency.frame_renderer(C.replace(warp_run, **{"camera.renderer": "jax"})) == "jax"
