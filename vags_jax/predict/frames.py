"""Camera frames as files: what ``python -m vags_jax.predict`` reads, and frames written from the
simulator so that the whole path can be tried without a robot.

A frame is four files (README "On a real robot" states the conventions once):

* colour: ``rgb.png`` (8-bit RGB or RGBA, alpha dropped) or ``.npy`` (h, w, 3) uint8, registered
  to the depth image (the same pixel grid);
* depth: ``depth.png`` 16-bit grey in millimetres, or ``.npy`` (h, w) float in metres; the
  z-distance along the optical axis, 0 (or NaN in .npy) where missing;
* intrinsics: ``K.json`` ``{"fx", "fy", "cx", "cy", "width", "height"}`` in pixels (pixel (u, v)
  = (column, row) looks along ((u - cx) / fx, (v - cy) / fy, 1) in the camera frame);
* pose: ``pose.json`` the (4, 4) camera-to-world transform in metres, OpenCV camera axes (x
  right, y down, z along the optical axis), world z up with the table top at
  ``workspace.table_z``: a bare 4 x 4 list of rows, or ``{"camera_to_world": [[...], ...]}``.

``ws.json`` (optional) moves the workspace square: ``{"center": [x, y], "table_z": z}``, plus
``size`` and ``heightmap_px``, which must equal the run's (its networks learned on that grid).

Every reader raises ``ValueError`` with one line naming the file and what to change.  PNGs are
read here with the standard library (zlib) and numpy, as ``vags_jax.benchmark.images`` writes them:
non-interlaced, 8- or 16-bit grey, grey + alpha, RGB, RGBA, or 8-bit palette.
"""
from __future__ import annotations

import json
import math
import os
import re
import struct
import zlib
from typing import Optional

import jax
import jax.numpy as jnp
import numpy as np

from vags_jax.benchmark.images import save_png
from vags_jax.config import Camera, Workspace

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
# colour type -> channels (PNG spec 11.2.2)
PNG_CHANNELS = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}
INTRINSICS_KEYS = ("fx", "fy", "cx", "cy", "width", "height")
WORKSPACE_KEYS = ("center", "size", "table_z", "heightmap_px")
MAX_DEPTH_MM = 65535  # a 16-bit PNG's largest value


# ----------------------------------------------------------------------------- PNG


def read_png(path: str) -> np.ndarray:
    """A PNG file -> (h, w) grey or (h, w, C) array (C = 2 grey + alpha, 3 RGB, 4 RGBA; a
    palette image comes back as RGB), uint8 for 8-bit files and uint16 for 16-bit ones.
    ValueError (one line) for a file that is not a PNG, is damaged, or uses a format this
    reader does not take (interlaced, 1-4 bit samples)."""
    with open(path, "rb") as f:
        data = f.read()
    if not data.startswith(PNG_SIGNATURE):
        raise ValueError(f"{path} is not a PNG file (no PNG signature)")
    pos, header, palette, idat = len(PNG_SIGNATURE), None, None, []
    while pos + 8 <= len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        crc = data[pos + 8 + length:pos + 12 + length]
        if len(body) != length or len(crc) != 4 or struct.unpack(">I", crc)[0] != zlib.crc32(kind + body) & 0xFFFFFFFF:
            raise ValueError(f"{path} is damaged (chunk {kind.decode('latin-1')!r} is cut short or fails its CRC)")
        pos += 12 + length
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"PLTE":
            palette = np.frombuffer(body, np.uint8).reshape(-1, 3)
        elif kind == b"IDAT":
            idat.append(body)
        elif kind == b"IEND":
            break
    if header is None or not idat:
        raise ValueError(f"{path} is damaged (no IHDR or IDAT chunk)")
    w, h, bits, ctype, _, _, interlace = header
    if ctype not in PNG_CHANNELS or bits not in (8, 16) or (ctype == 3 and bits != 8):
        raise ValueError(f"{path} has {bits}-bit samples of PNG colour type {ctype}; save it as 8-bit RGB "
                         f"(colour) or 16-bit grey (depth)")
    if interlace:
        raise ValueError(f"{path} is an interlaced PNG; save it without interlacing")
    channels = PNG_CHANNELS[ctype]
    bpp = channels * bits // 8  # bytes per pixel
    try:
        raw = np.frombuffer(zlib.decompress(b"".join(idat)), np.uint8)
    except zlib.error as e:
        raise ValueError(f"{path} is damaged (its image data does not decompress: {e})") from None
    if raw.size != h * (1 + w * bpp):
        raise ValueError(f"{path} is damaged ({raw.size} bytes of image data, {h * (1 + w * bpp)} expected)")
    rows = raw.reshape(h, 1 + w * bpp)
    pixels = _unfilter(rows[:, 0], rows[:, 1:].reshape(h, w, bpp), path)
    if bits == 16:
        pixels = pixels.reshape(h, w, channels, 2)
        pixels = (pixels[..., 0].astype(np.uint16) << 8) | pixels[..., 1]
    else:
        pixels = pixels.reshape(h, w, channels)
    if ctype == 3:
        if palette is None or pixels.max(initial=0) >= len(palette):
            raise ValueError(f"{path} is damaged (palette image without a fitting PLTE chunk)")
        return palette[pixels[..., 0]]
    return pixels[..., 0] if channels == 1 else pixels


def _unfilter(kinds: np.ndarray, raw: np.ndarray, path: str) -> np.ndarray:
    """Undoes PNG's per-row filters (spec 9.2) -> (h, w, bpp) uint8.  raw (h, w, bpp) uint8,
    kinds (h,) the filter type of each row.  Pixel (r, j) depends on (r, j - 1), (r - 1, j) and
    (r - 1, j - 1) only, so the pixels of one anti-diagonal r + j = d are independent: h + w - 1
    vectorised steps instead of a loop over every byte."""
    h, w, bpp = raw.shape
    if kinds.size and kinds.max() > 4:
        raise ValueError(f"{path} is damaged (unknown row filter {int(kinds.max())})")
    if np.isin(kinds, (0, 2)).all():
        out = raw.copy()  # None and Up only: a running sum down each column, row by row
        for r in np.flatnonzero(kinds == 2):
            out[r] += out[r - 1] if r > 0 else 0
        return out
    out = np.zeros((h + 1, w + 1, bpp), np.int32)  # row 0 and column 0: the zeros before the image
    src = raw.astype(np.int32)
    for d in range(h + w - 1):
        r = np.arange(max(0, d - w + 1), min(h - 1, d) + 1)
        j = d - r
        x, kind = src[r, j], kinds[r][:, None]
        a, b, c = out[r + 1, j], out[r, j + 1], out[r, j]  # left, up, upper left
        p = a + b - c
        pa, pb, pc = np.abs(p - a), np.abs(p - b), np.abs(p - c)
        paeth = np.where((pa <= pb) & (pa <= pc), a, np.where(pb <= pc, b, c))
        pred = np.select([kind == 1, kind == 2, kind == 3, kind == 4], [a, b, (a + b) // 2, paeth], 0)
        out[r + 1, j + 1] = (x + pred) & 0xFF
    return out[1:, 1:].astype(np.uint8)


# ----------------------------------------------------------------------------- reading frames


def _ext(path: str) -> str:
    return os.path.splitext(path)[1].lower()


def _exists(path: str, what: str) -> None:
    if not os.path.exists(path):
        raise ValueError(f"{what} {path}: no such file")
    if os.path.isdir(path):
        raise ValueError(f"{what} {path} is a directory; give the file")


def _npy(path: str) -> np.ndarray:
    try:
        return np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError) as e:
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise ValueError(f"{path} is not a readable .npy array ({first}); save it with numpy.save") from None


def read_rgb(path: str) -> np.ndarray:
    """The colour image -> (h, w, 3) uint8.  ``.png``: 8-bit RGB, RGBA (alpha dropped) or
    palette; ``.npy``: (h, w, 3) uint8."""
    _exists(path, "colour image")
    if _ext(path) == ".npy":
        rgb = _npy(path)
        if rgb.dtype != np.uint8:
            raise ValueError(f"{path} holds {rgb.dtype} values; the colour image must be uint8 in 0..255 "
                             f"(for floats in [0, 1] save (rgb * 255).round().astype(np.uint8))")
    elif _ext(path) == ".png":
        rgb = read_png(path)
        if rgb.dtype == np.uint16:
            hint = " (is it the depth image?)" if rgb.ndim == 2 else ""
            raise ValueError(f"{path} is a 16-bit PNG{hint}; the colour image must be 8-bit RGB")
        if rgb.ndim == 2 or rgb.shape[-1] == 2:
            raise ValueError(f"{path} is a grey image; give the camera's colour (RGB) image, registered to the depth")
        rgb = rgb[..., :3]
    else:
        raise ValueError(f"{path}: the colour image must be a .png (8-bit RGB) or .npy (h, w, 3) uint8 file; "
                         f"convert other formats to PNG")
    if rgb.ndim != 3 or rgb.shape[-1] != 3:
        raise ValueError(f"{path} has shape {rgb.shape}; the colour image must be (height, width, 3) RGB")
    return np.ascontiguousarray(rgb)


def read_depth(path: str) -> np.ndarray:
    """The depth image -> (h, w) float32 metres, 0 where missing.  ``.png``: 16-bit grey in
    millimetres; ``.npy``: (h, w) float metres (NaN and inf count as missing)."""
    _exists(path, "depth image")
    if _ext(path) == ".npy":
        depth = _npy(path)
        if depth.ndim == 3 and depth.shape[-1] == 1:
            depth = depth[..., 0]
        if not np.issubdtype(depth.dtype, np.floating):
            raise ValueError(f"{path} holds {depth.dtype} values; depth in a .npy file must be float metres "
                             f"(divide millimetres by 1000), or save millimetres as a 16-bit PNG")
        depth = np.where(np.isfinite(depth), depth, 0.0).astype(np.float32)
    elif _ext(path) == ".png":
        img = read_png(path)
        if img.ndim != 2:
            raise ValueError(f"{path} is a colour image (a false-colour picture of depth?); depth must be a "
                             f"16-bit grey PNG in millimetres, as the sensor gives it")
        if img.dtype != np.uint16:
            raise ValueError(f"{path} is an 8-bit PNG; depth must be a 16-bit grey PNG in millimetres "
                             f"(e.g. cv2.imwrite(path, depth_mm.astype(np.uint16))), or .npy in metres")
        depth = img.astype(np.float32) / 1000.0
    else:
        raise ValueError(f"{path}: the depth image must be a .png (16-bit, millimetres) or .npy (float, metres) file")
    if depth.ndim != 2:
        raise ValueError(f"{path} has shape {depth.shape}; the depth image must be (height, width)")
    if not np.any(depth > 0):
        raise ValueError(f"{path} holds no valid depth (every pixel is 0 or NaN); check the depth stream "
                         f"(is the sensor on and in range, the right image saved?)")
    return depth


def _json(path: str, what: str):
    _exists(path, what)
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except (ValueError, UnicodeDecodeError) as e:
        raise ValueError(f"{what} {path} is not valid JSON ({str(e).splitlines()[0]})") from None


def _number(path: str, key: str, value, integer: bool = False):
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    if integer:
        ok = ok and float(value).is_integer()
    if not ok:
        kind = "a whole number" if integer else "a finite number"
        raise ValueError(f"{path}: {key} must be {kind}, got {value!r}")
    return int(value) if integer else float(value)


def read_intrinsics(path: str) -> Camera:
    """``{"fx", "fy", "cx", "cy", "width", "height"}`` (pixels) -> the Camera config that the
    heightmap projection takes (near, far, the global pose and the sensor model keep their
    defaults: a frame's projection does not use them)."""
    k = _json(path, "intrinsics")
    if not isinstance(k, dict):
        raise ValueError(f"{path}: intrinsics must be a JSON object with keys {', '.join(INTRINSICS_KEYS)}")
    missing = [n for n in INTRINSICS_KEYS if n not in k]
    unknown = sorted(set(k) - set(INTRINSICS_KEYS))
    if missing or unknown:
        raise ValueError(f"{path}: intrinsics need exactly the keys {', '.join(INTRINSICS_KEYS)} (pixels); "
                         + (f"missing {missing}" if missing else f"unknown {unknown}"))
    vals = {n: _number(path, n, k[n], integer=n in ("width", "height")) for n in INTRINSICS_KEYS}
    try:
        return Camera(**vals)
    except ValueError as e:
        raise ValueError(f"{path}: {e}") from None


def _pose_matrix(path: str, p) -> np.ndarray:
    if not (isinstance(p, list) and len(p) == 4 and all(isinstance(r, list) and len(r) == 4 for r in p)):
        raise ValueError(f"{path}: the pose must be a 4 x 4 list of rows (the camera-to-world transform)")
    return np.array([[_number(path, "every pose entry", v) for v in r] for r in p], np.float64)


def read_pose(path: str) -> np.ndarray:
    """The camera-to-world pose -> (4, 4) float64.  Only its form is checked here; whether it
    is a rigid transform in metres looking at the table is checked with the frame
    (``heightmap.check_frame``)."""
    p = _json(path, "pose")
    if isinstance(p, dict):
        if set(p) != {"camera_to_world"}:
            raise ValueError(f"{path}: a pose object must have the one key 'camera_to_world' (a 4 x 4 list of "
                             f"rows), got keys {sorted(p)}")
        p = p["camera_to_world"]
    return _pose_matrix(path, p)


def read_workspace(path: str) -> dict:
    """``ws.json`` -> workspace overrides ``{"workspace.center": (x, y), ...}`` (keys of
    ``WORKSPACE_KEYS``)."""
    ws = _json(path, "workspace")
    if not isinstance(ws, dict) or not ws:
        raise ValueError(f"{path}: the workspace must be a JSON object with some of the keys {', '.join(WORKSPACE_KEYS)}")
    unknown = sorted(set(ws) - set(WORKSPACE_KEYS))
    if unknown:
        raise ValueError(f"{path}: unknown workspace keys {unknown}; valid: {', '.join(WORKSPACE_KEYS)}")
    out = {}
    for k, v in ws.items():
        if k == "center":
            if not (isinstance(v, list) and len(v) == 2):
                raise ValueError(f"{path}: center must be [x, y] in metres, got {v!r}")
            out["workspace.center"] = tuple(_number(path, "center", c) for c in v)
        else:
            out[f"workspace.{k}"] = _number(path, k, v, integer=k == "heightmap_px")
    return out


def check_size(rgb: np.ndarray, depth: np.ndarray, cam: Camera, rgb_path: str, depth_path: str,
               k_path: str) -> None:
    """The colour and depth images must both have the size the intrinsics describe."""
    want = (cam.height, cam.width)
    if depth.shape != want:
        raise ValueError(f"{depth_path} is {depth.shape[1]} x {depth.shape[0]} pixels but {k_path} says width "
                         f"{cam.width}, height {cam.height}: give the intrinsics of the stream this image came from "
                         f"(a resized image scales fx, fy, cx, cy by the same factor)")
    if rgb.shape[:2] != want:
        raise ValueError(f"{rgb_path} is {rgb.shape[1]} x {rgb.shape[0]} pixels but the depth image and {k_path} "
                         f"are {cam.width} x {cam.height}: register the colour image to the depth image (same "
                         f"size and pixel grid)")


# ----------------------------------------------------------------------------- writing frames


def intrinsics_dict(cam: Camera) -> dict:
    cx, cy = cam.principal_point
    return {"fx": cam.fx, "fy": cam.fy, "cx": cx, "cy": cy, "width": cam.width, "height": cam.height}


def workspace_dict(ws: Workspace) -> dict:
    return {"center": list(ws.center), "size": ws.size, "table_z": ws.table_z, "heightmap_px": ws.heightmap_px}


def json_text(obj) -> str:
    """JSON with one key a line and every list of plain values on one line (a pose's rows)."""
    def one_line(m):
        inner = m.group(0)[1:-1].strip()
        return "[" + ", ".join(v.strip() for v in inner.split(",")) + "]" if inner else "[]"

    value = r"\s*(?:-?[0-9][0-9.eE+-]*|null|true|false)\s*"
    return re.sub(rf"\[(?:{value}(?:,{value})*)?\]", one_line, json.dumps(obj, indent=1))


def _write_json(path: str, obj) -> None:
    with open(path, "w", encoding="utf-8") as f:
        f.write(json_text(obj) + "\n")


def write_frame(directory: str, rgb, depth, pose, cam: Camera, ws: Optional[Workspace] = None,
                prefix: str = "", depth_format: str = "png") -> dict:
    """Writes one frame as ``predict`` reads it: ``{prefix}rgb.png``, ``{prefix}depth.png``
    (16-bit millimetres, rounded; or ``{prefix}depth.npy`` float32 metres with
    ``depth_format="npy"``), ``{prefix}pose.json``, ``K.json`` and (``ws``) ``ws.json`` ->
    {"rgb", "depth", "pose", "intrinsics", "workspace"} paths.  rgb (h, w, 3) uint8, depth (h, w)
    metres (0 = missing), pose (4, 4) camera-to-world."""
    if depth_format not in ("png", "npy"):
        raise ValueError(f"depth_format must be 'png' or 'npy', got {depth_format!r}")
    os.makedirs(directory, exist_ok=True)
    depth = np.asarray(depth, np.float32)
    paths = {n: os.path.join(directory, f"{prefix}{n}.{e}") for n, e in
             (("rgb", "png"), ("depth", depth_format), ("pose", "json"))}
    paths["intrinsics"] = os.path.join(directory, "K.json")
    save_png(paths["rgb"], np.asarray(rgb, np.uint8))
    if depth_format == "png":
        save_png(paths["depth"], np.clip(np.round(np.nan_to_num(depth) * 1000.0), 0, MAX_DEPTH_MM).astype(np.uint16))
    else:
        np.save(paths["depth"], depth)
    # float32 values written as their shortest decimal (the simulator's poses are float32).
    pose32 = np.asarray(pose, np.float32)
    _write_json(paths["pose"], {"camera_to_world": [[float(str(v)) for v in r] for r in pose32]})
    _write_json(paths["intrinsics"], intrinsics_dict(cam))
    if ws is not None:
        paths["workspace"] = os.path.join(directory, "ws.json")
        _write_json(paths["workspace"], workspace_dict(ws))
    return paths


# ----------------------------------------------------------------------------- frames from the simulator


def scene_state(env, seed: int, n_objects: int):
    """The simulated scene of ``seed`` with ``n_objects`` objects (one world, dropped and
    settled as in training: ``VagsEnv.reset``) -> EnvState.  The same arguments give the same
    scene, so a later call can render it from another pose or grasp in it."""
    return env.reset(jax.random.PRNGKey(seed), np.array([n_objects]))


def render_frame(env, sim_state, pose, key=None):
    """World 0 of ``sim_state`` (``SimState``) seen by the env's camera from ``pose`` (4, 4),
    sensor model included (``VagsEnv.camera_image``; key: its noise) -> (rgb (h, w, 3) uint8,
    depth (h, w) float32 metres, pose (4, 4) float32) as numpy."""
    pose = jnp.broadcast_to(jnp.asarray(pose, jnp.float32), (sim_state.n_worlds, 4, 4))
    if key is None and env.cfg.camera.noise.enabled:
        key = jax.random.PRNGKey(0)
    image = jax.jit(env.camera_image)(sim_state, pose, key)
    return np.asarray(image.rgb[0]), np.asarray(image.depth[0]), np.asarray(image.pose[0])


def simulator_frame_key(seed: int, pose_index: int):
    """The sensor-noise key of the simulator commands in scene ``seed``: 0 for write-frames'
    global view, 1 for its frame at another pose, 2 for execute's view after the grasp."""
    return jax.random.fold_in(jax.random.PRNGKey(seed), 1000 + pose_index)


def pose_from_file(path: str) -> np.ndarray:
    """A pose to render at: a pose file (``read_pose``), or ``predict``'s JSON output, whose
    ``viewpoint.camera_to_world`` is taken."""
    obj = _json(path, "pose")
    if isinstance(obj, dict) and "decision" in obj:
        view = obj.get("viewpoint")
        if not isinstance(view, dict) or "camera_to_world" not in view:
            raise ValueError(f"{path} is a predict output without a viewpoint (decision {obj['decision']!r}): "
                             f"there is no camera move to render")
        return _pose_matrix(path, view["camera_to_world"])
    return read_pose(path)


__all__ = ["read_png", "read_rgb", "read_depth", "read_intrinsics", "read_pose", "read_workspace", "check_size",
           "write_frame", "intrinsics_dict", "workspace_dict", "scene_state", "render_frame", "simulator_frame_key",
           "pose_from_file", "json_text", "INTRINSICS_KEYS", "WORKSPACE_KEYS"]
