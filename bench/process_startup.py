#!/usr/bin/env python3
"""What an ``eval.py`` (or ``train.py``) process pays before its first round: the imports, the
backend's start, and loading small programs from the persistent compile cache.

    python bench/process_startup.py --out OUT/startup.json [--programs 40] [--cache-dir DIR]

Each part runs in fresh child processes of this Python, so that nothing is imported or compiled
beforehand:

* ``imports``: ``python -X importtime -c "import eval"`` (eval.py's imports, as ``process_s``'s
  ``imports_s`` counts them): the wall time of the child, and the modules eval.py's import
  brought in first-hand that took longest (cumulative seconds: a module shared by two is
  counted where Python first imported it), and what the first import of each main package
  cost (jax, mujoco, warp, flax, ...);
* ``backend``: the first ``jax.devices()`` after ``import jax`` (the platform's start, on a GPU
  CUDA's), timed inside a child;
* ``programs``: ``--programs`` distinct small jitted programs (one eager-sized op each, the kind
  a process runs outside its large programs), run once in a child with an empty cache directory
  (compiled and written) and once in a second child (loaded): seconds per program either way,
  from JAX's own compile clock (``compile_cache.CompileClock``).

Needs only jax for ``backend`` and ``programs``; ``imports`` needs what eval.py needs.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

_PROGRAMS_CHILD = r"""
import json, sys, time
sys.path.insert(0, {root!r})
from vags_jax import compile_cache
compile_cache.enable({cache!r})
import jax, numpy as np
jax.devices()
n = {n}
with compile_cache.CompileClock() as clock:
    t0 = time.perf_counter()
    for k in range(1, n + 1):  # one program per shape: x + 1 on (k,) float32 (numpy in: no other program)
        jax.jit(lambda x: x + 1)(np.zeros((k,), np.float32)).block_until_ready()
    wall = time.perf_counter() - t0
print(json.dumps({{"wall_s": wall, **clock.as_dict()}}))
"""

_BACKEND_CHILD = r"""
import json, time
t0 = time.perf_counter()
import jax
t1 = time.perf_counter()
d = jax.devices()
t2 = time.perf_counter()
print(json.dumps({"import_jax_s": t1 - t0, "devices_s": t2 - t1, "devices": [str(x) for x in d]}))
"""


def _child(code: str, env=None) -> dict:
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=ROOT)
    if out.returncode != 0:
        raise RuntimeError(f"child failed ({out.returncode}): {out.stderr[-2000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def importtime_top(stderr: str, top: int, level: int = 1) -> list:
    """``-X importtime`` output -> the ``top`` modules of nesting ``level`` (0: the module
    imported, 1: what it imported itself) by cumulative seconds: [{"module", "seconds"}]."""
    rows = []
    for line in stderr.splitlines():
        m = re.match(r"import time:\s*(\d+)\s*\|\s*(\d+)\s*\|( *)(\S+)", line)
        if m and len(m.group(3)) == 1 + 2 * level:  # Python indents each level by two spaces
            rows.append({"module": m.group(4), "seconds": int(m.group(2)) / 1e6})
    return sorted(rows, key=lambda r: -r["seconds"])[:top]


PACKAGES = ("jax", "jaxlib", "numpy", "scipy", "mujoco", "warp", "flax", "optax", "orbax", "chex", "vags_jax")


def package_seconds(stderr: str) -> dict:
    """``-X importtime`` output -> {package: seconds of its outermost import} for ``PACKAGES``
    (what importing it first cost, the packages it pulled in first included)."""
    out = {}
    for line in stderr.splitlines():
        m = re.match(r"import time:\s*(\d+)\s*\|\s*(\d+)\s*\|\s*(\S+)", line)
        if m and m.group(3).split(".")[0] in PACKAGES:
            root = m.group(3).split(".")[0]
            out[root] = max(out.get(root, 0.0), int(m.group(2)) / 1e6)
    return dict(sorted(out.items(), key=lambda kv: -kv[1]))


def imports(top: int) -> dict:
    t0 = time.perf_counter()
    out = subprocess.run([sys.executable, "-X", "importtime", "-c", "import eval"], capture_output=True,
                         text=True, cwd=ROOT)
    wall = time.perf_counter() - t0
    if out.returncode != 0:
        raise RuntimeError(f"import eval failed: {out.stderr[-2000:]}")
    return {"wall_s": round(wall, 3), "top": importtime_top(out.stderr, top), "packages": package_seconds(out.stderr)}


def programs(n: int, cache_dir: str) -> dict:
    code = _PROGRAMS_CHILD.format(root=ROOT, cache=cache_dir, n=n)
    first, second = _child(code), _child(code)
    return {"n": n, "first": first, "second": second,
            "compile_ms_per_program": round(1e3 * first["seconds"] / n, 2),
            "load_ms_per_program": round(1e3 * second["seconds"] / n, 2)}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", required=True, help="JSON report path")
    p.add_argument("--programs", type=int, default=40, help="small programs to compile, then load (default 40)")
    p.add_argument("--cache-dir", default=None, help="an empty directory for the programs' cache (default: a new "
                                                     "temporary one)")
    p.add_argument("--top", type=int, default=12, help="top-level imports to list (default 12)")
    p.add_argument("--skip-imports", action="store_true", help="leave out eval.py's imports (they need mujoco)")
    args = p.parse_args(argv)
    if args.programs < 1:
        p.error(f"--programs must be at least 1, got {args.programs}")
    with tempfile.TemporaryDirectory() as tmp:
        cache = args.cache_dir or tmp
        if os.path.isdir(cache) and os.listdir(cache):
            p.error(f"--cache-dir {cache!r} is not empty: the first pass must compile")
        report = {"backend": _child(_BACKEND_CHILD), "programs": programs(args.programs, cache)}
    if not args.skip_imports:
        report["imports"] = imports(args.top)
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, "w") as f:
        json.dump(report, f, indent=1)
    b, g = report["backend"], report["programs"]
    print(f"import jax {b['import_jax_s']:.2f} s, first jax.devices() {b['devices_s']:.2f} s ({', '.join(b['devices'])})")
    print(f"{g['n']} small programs: {g['compile_ms_per_program']} ms each compiled, {g['load_ms_per_program']} ms "
          f"each loaded from the cache ({g['second']['loaded']} loaded, {g['second']['compiled']} compiled)")
    if "imports" in report:
        print(f"import eval: {report['imports']['wall_s']} s in a child; its longest first-hand imports:")
        for r in report["imports"]["top"]:
            print(f"  {r['seconds']:7.3f} s  {r['module']}")
        print("first import of each package (what it pulled in first included): " + ", ".join(
            f"{k} {v:.2f} s" for k, v in report["imports"]["packages"].items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
