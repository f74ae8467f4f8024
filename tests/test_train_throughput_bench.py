"""bench/train_throughput.py --updates-only runs where MuJoCo is not installed (the GPU machines
lend jax and flax without it): importing the script, which holds everything an update measurement
uses, and the config loads no MuJoCo and no Warp."""
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_update_measurement_loads_no_mujoco():
    code = ("import sys; sys.path[:0] = ['bench']; import train_throughput; "
            "import jax, vags_jax.config as C; cfg = C.tiny(); "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('mujoco', 'warp')))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip() == "[]", out.stdout
