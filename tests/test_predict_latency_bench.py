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


def test_its_random_runs_load_as_a_policy_under_each_gate(tmp_path):
    """``--config PRESET`` times a run of random networks: FramePolicy must accept it under the
    preset's gate (the success gate's mean success after a move needs 3 calibration entries; the
    rate gate needs a table measured on those networks), else the script stops before timing."""
    from vags_jax.predict import FramePolicy

    for gate in ("success", "rate", "q"):
        cfg = C.replace(C.preset("tiny"), **{"vags.gate": gate})
        run = predict_latency.random_run(cfg, str(tmp_path / gate))
        assert FramePolicy(run).source == "stage3 step 1"
