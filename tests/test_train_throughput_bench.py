"""bench/train_throughput.py --updates-only runs where MuJoCo is not installed (the GPU machines
lend jax and flax without it): a real run on the tiny config, its update measured without its
parts, writes its figures and loads no MuJoCo and no Warp."""
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_updates_only_measures_the_update_without_mujoco(tmp_path):
    out = str(tmp_path / "mfu.json")
    code = ("import sys; sys.path[:0] = ['bench']; import train_throughput; "
            f"train_throughput.main(['--config', 'tiny', '--updates-only', '--no-parts', '--trunks', 'small', "
            f"'--matmul', '64', '--cache-dir', 'off', '--out', {out!r}]); "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('mujoco', 'warp')))")
    proc = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip().splitlines()[-1] == "[]", proc.stdout
    with open(out) as f:
        r = json.load(f)
    assert r["updates_only"] and "attempts_per_s" not in r
    (u,) = r["update_mfu"]
    assert u["trunk"] == "small" and u["parts"] == {} and u["xla_flops"] is None
    assert u["update_flops"] > 0 and u["updates_per_s"] > 0 and 0 < u["mfu"]
