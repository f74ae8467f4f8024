"""When do MuJoCo Warp's kernel modules come into being?  On CPU (MuJoCo Warp runs there too),
the tests' tiny scene under MJX impl "warp": Warp's module registry after building the
simulator, after lowering and compiling a settle program, and after running it once.
Run from the repository root: PYTHONPATH=. python bench/results/warp_modules/warp_modules_cpu.py
(bench/RESULTS.md, "twentieth look")."""
import sys
import time

import jax
from warp._src import context as wctx

sys.path.insert(0, "tests")
from grasp_scenarios import tiny_config  # noqa: E402
from vags_jax.sim.scene import build_scene  # noqa: E402
from vags_jax.sim.simulator import Simulator  # noqa: E402


def mods(tag):
    """Prints and returns the names in Warp's module registry."""
    names = sorted(wctx.user_modules)
    loc = [n for n in names if "locals" in n]
    print(tag, len(names), "modules,", len(loc), "locals", flush=True)
    return set(names)


cfg = tiny_config(**{"sim.impl": "warp"})
mods("after import")
sim = Simulator(cfg, build_scene(cfg))
m1 = mods("after Simulator")
st = sim.empty(2)
m2 = mods("after empty (ran)")
f = jax.jit(lambda s: sim.settle(s, 0.01))
lo = f.lower(st)
m3 = mods("after lower settle")
c = lo.compile()
m4 = mods("after compile")
t = time.time()
jax.block_until_ready(c(st))
print("ran", time.time() - t, flush=True)
m5 = mods("after run")
print("new at run:", sorted(m5 - m4)[:40])
print("new at lower:", sorted(m3 - m2)[:40])
print("new at empty:", sorted(m2 - m1)[:40])
