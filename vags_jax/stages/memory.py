"""A lower bound of a training stage's device memory, checked before anything compiles.

The bound counts only arrays whose size is known from the config, at their smallest:

* replay: ``replay.capacity`` transitions of ``REPLAY_BYTES_PER_CELL`` bytes per heightmap cell
  (stage 1 keeps one replay; stages 2 and 3 two, GDNet's and VANet's);
* Q maps: per world ``net.n_rotations`` x px x px float32 values, once in stage 1 and twice in
  stages 2 and 3 (GDNet on the global and on the fused close view);
* depth images: per world one camera image of float32 metres.

Network activations, XLA's temporary buffers and the physics state come on top, so a stage
that passes may still run out of memory; one whose bound exceeds the device's memory cannot
fit and is refused (``train.py --no-memory-check`` skips the check, e.g. for unified memory).
The device's memory is JAX's ``bytes_limit`` on a GPU, the machine's RAM on a CPU.
"""
from __future__ import annotations

import os
from typing import Optional

import jax

from vags_jax import config as C

GIB = 2**30


def stage_bytes(cfg, name: str) -> int:
    """The lower bound (bytes) of stage ``name`` ("stage1" | "stage2" | "stage3") of ``cfg``, on
    each device (stage 1 over ``parallel.devices`` devices holds a share of worlds and replay)."""
    px, cam = cfg.workspace.heightmap_px, cfg.camera
    d = cfg.parallel.devices if name == "stage1" else 1  # data parallel: one device's share
    n = getattr(cfg, name).n_worlds // d
    copies = 1 if name == "stage1" else 2
    replay = copies * (cfg.replay.capacity // d) * C.REPLAY_BYTES_PER_CELL * px * px
    q_maps = copies * n * cfg.net.n_rotations * px * px * 4
    depth = n * cam.width * cam.height * 4
    return replay + q_maps + depth


def device_bytes() -> Optional[int]:
    """Memory of JAX's first device in bytes (a GPU's ``bytes_limit``; on a CPU the machine's
    RAM), or None when it cannot be told."""
    stats = jax.devices()[0].memory_stats() or {}
    if stats.get("bytes_limit"):
        return int(stats["bytes_limit"])
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):  # not a POSIX system
        return None


def peak_gib() -> Optional[float]:
    """The most device memory JAX's first device has held at once so far in this process, in GiB
    (the allocator's ``peak_bytes_in_use``: arrays and XLA's temporary buffers, not the pool it
    preallocated), or None where the device does not report it (a CPU)."""
    try:
        stats = jax.devices()[0].memory_stats() or {}
    except Exception:  # a backend without memory statistics
        return None
    peak = stats.get("peak_bytes_in_use")
    return round(peak / GIB, 2) if peak else None


def check_fits(cfg, names, have: Optional[int]) -> None:
    """ValueError naming the first stage of ``names`` whose lower bound exceeds ``have`` bytes."""
    if have is None:
        return
    for name in names:
        if name not in ("stage1", "stage2", "stage3") or not getattr(cfg, name).iterations:
            continue
        need = stage_bytes(cfg, name)
        if need > have:
            n = getattr(cfg, name).n_worlds
            d = cfg.parallel.devices if name == "stage1" else 1
            worlds = f"{n:,} worlds" if d == 1 else f"{n // d:,} worlds on each of {d} devices"
            raise ValueError(
                f"{name}: {worlds} need at least {need / GIB:,.1f} GiB of device memory (replay, Q maps "
                f"and depth images alone; docs/architecture.md, 'Memory'), more than the {have / GIB:,.1f} GiB "
                f"of {jax.devices()[0].platform}; lower {name}.n_worlds or replay.capacity (or pass "
                f"--no-memory-check to try anyway)")


__all__ = ["stage_bytes", "device_bytes", "peak_gib", "check_fits"]
