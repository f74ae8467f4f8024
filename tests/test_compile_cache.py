"""The on-disk compile cache (vags_jax/compile_cache.py): where it lives, its errors, and that a
second process loads what the first compiled."""
import os
import subprocess
import sys

import jax
import jax.numpy as jnp
import pytest

from vags_jax import compile_cache

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_where_the_cache_lives(monkeypatch, tmp_path):
    monkeypatch.delenv(compile_cache.ENV, raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert compile_cache.resolve(None) == str(tmp_path / "xdg" / "vags_jax" / "compiled")
    monkeypatch.setenv(compile_cache.ENV, str(tmp_path / "env"))
    assert compile_cache.resolve(None) == str(tmp_path / "env")
    assert compile_cache.resolve(str(tmp_path / "flag")) == str(tmp_path / "flag")  # the flag wins
    assert compile_cache.resolve("off") is None and compile_cache.resolve("OFF") is None
    monkeypatch.setenv(compile_cache.ENV, "off")
    assert compile_cache.resolve(None) is None


def test_an_unusable_directory_is_one_clear_error(tmp_path):
    before = jax.config.jax_compilation_cache_dir
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    with pytest.raises(ValueError, match=r"--cache-dir .*a_file.*cannot create it.*writable directory or 'off'"):
        compile_cache.enable(str(a_file))
    assert jax.config.jax_compilation_cache_dir == before  # nothing changed


def test_the_clock_tells_a_compile_from_a_load():
    """A new program compiles; the same program built again (a new function object, so JAX
    traces it anew) is read from this session's cache (conftest turns the cache on)."""
    def make():
        return jax.jit(lambda x: jnp.sin(x) * 3.25 + 0.125)

    x = jnp.arange(7.0)
    with compile_cache.CompileClock() as first:
        make()(x).block_until_ready()
    with compile_cache.CompileClock() as second:
        make()(x).block_until_ready()
    with compile_cache.CompileClock() as third:
        make()  # built but never called: nothing
    assert first.compiled + first.loaded == 1  # loaded when an earlier session left it in the cache
    assert (second.compiled, second.loaded) == (0, 1) and second.as_dict()["loaded"] == 1
    assert (third.compiled, third.loaded, third.seconds) == (0, 0, 0.0)


def test_a_closed_clock_stops_counting():
    """``close`` (what eval.py calls once the policy is built) stops the count; a second close
    does nothing."""
    x = jnp.arange(9.0)
    clock = compile_cache.CompileClock().__enter__()
    jax.jit(lambda x: jnp.cos(x) * 1.75 - 0.5)(x).block_until_ready()
    clock.close()
    clock.close()
    seen = (clock.backend, clock.loaded)
    jax.jit(lambda x: jnp.cos(x) * 2.75 - 0.5)(x).block_until_ready()
    assert seen[0] == 1 and (clock.backend, clock.loaded) == seen


PROGRAM = """
import sys, jax, jax.numpy as jnp
from vags_jax import compile_cache
compile_cache.enable(sys.argv[1])
with compile_cache.CompileClock() as c:
    jax.jit(lambda x: jnp.cumsum(x) * 1.5)(jnp.arange(5.0)).block_until_ready()
print(c.compiled, c.loaded)
"""


def test_a_second_process_loads_what_the_first_compiled(tmp_path):
    cache = str(tmp_path / "cache")
    env = {k: v for k, v in os.environ.items() if k not in (compile_cache.ENV, "JAX_COMPILATION_CACHE_DIR")}

    def run():
        out = subprocess.run([sys.executable, "-c", PROGRAM, cache], cwd=ROOT, env=env, capture_output=True,
                             text=True, timeout=300)
        assert out.returncode == 0, out.stderr
        return tuple(int(v) for v in out.stdout.split())

    compiled, loaded = run()  # the program and jnp.arange's
    assert compiled >= 1 and loaded == 0
    assert len(os.listdir(os.path.join(cache, "jax"))) >= compiled  # the executables are on disk
    assert run() == (0, compiled)
