"""vags_jax/cpu_compile.py: which of XLA's faster-compile CPU flags a command adds to XLA_FLAGS,
and the record of what this jaxlib accepts, with a stand-in probe (no child JAX process)."""
import json
import os

from vags_jax import cpu_compile as cc

F, O = cc.FUSION, cc.OPT_LEVEL


def test_wanted_adds_them_only_off_a_gpu_and_keeps_the_callers_settings():
    assert cc.wanted({}, gpu=False) == [F, O]
    assert cc.wanted({}, gpu=True) == []  # the level would also set a GPU's kernels' LLVM level
    assert cc.wanted({"XLA_FLAGS": "--xla_backend_optimization_level=3"}, gpu=False) == [F]
    assert cc.wanted({"XLA_FLAGS": "--xla_cpu_use_fusion_emitters=true --x=1"}, gpu=False) == [O]
    assert cc.wanted({cc.ENV: "off"}, gpu=False) == []


def test_gpu_possible_follows_jax_platforms():
    assert not cc.gpu_possible({"JAX_PLATFORMS": "cpu"})
    assert cc.gpu_possible({"JAX_PLATFORMS": "cuda,cpu"})


def test_accepted_tries_once_per_jaxlib_and_falls_back_flag_by_flag(tmp_path):
    tried = []

    def probe(flags):  # this "jaxlib" knows the fusion flag, not the level
        tried.append(flags)
        return O not in flags

    assert cc.accepted([F, O], "--base=1", str(tmp_path), probe) == [F]
    assert tried == [f"--base=1 {F} {O}", f"--base=1 {F}", f"--base=1 {O}"]
    record = json.load(open(os.path.join(tmp_path, cc.RECORD)))
    assert list(record.values()) == [{F: True, O: False}]
    tried.clear()
    assert cc.accepted([F, O], "--base=1", str(tmp_path), probe) == [F]  # from the record
    assert tried == []
    assert cc.accepted([F], "", None, lambda flags: True) == [F]  # no record: tried each time


def test_add_flags_appends_to_the_callers_xla_flags(tmp_path, monkeypatch):
    monkeypatch.setattr(cc, "gpu_possible", lambda environ=None: False)
    env = {"XLA_FLAGS": "--xla_force_host_platform_device_count=2"}
    assert cc.add_flags(str(tmp_path), env, probe=lambda flags: True) == [F, O]
    assert env["XLA_FLAGS"] == f"--xla_force_host_platform_device_count=2 {F} {O}"
    assert cc.add_flags(str(tmp_path), env, probe=lambda flags: True) == []  # already there
    env = {}
    assert cc.add_flags(str(tmp_path / "none"), env, probe=lambda flags: False) == []
    assert "XLA_FLAGS" not in env
