"""Writing pictures (PNG) with the standard library only, and false-colour maps for depth/heights.

(``vags_jax.predict.frames`` reads PNGs back: camera frames from files.)"""
from __future__ import annotations

import struct
import zlib

import numpy as np


def save_png(path: str, image: np.ndarray) -> None:
    """Writes a PNG.  ``image``: (H, W) grey or (H, W, 3) RGB, uint8 (floats in [0, 1] ok), or
    (H, W) uint16 grey, written as a 16-bit PNG (depth images in millimetres)."""
    img = np.asarray(image)
    bits = 16 if img.dtype == np.uint16 and img.ndim == 2 else 8
    if bits == 16:
        img = img.astype(">u2")  # PNG samples are big-endian
    elif img.dtype != np.uint8:
        if not np.issubdtype(img.dtype, np.floating):
            raise ValueError(f"save_png wants uint8 or float images, got {img.dtype}")
        img = (np.clip(np.nan_to_num(img), 0.0, 1.0) * 255 + 0.5).astype(np.uint8)
    if img.ndim == 2:
        colour_type, channels = 0, 1
    elif img.ndim == 3 and img.shape[2] == 3:
        colour_type, channels = 2, 3
    else:
        raise ValueError(f"save_png wants (H, W) or (H, W, 3), got shape {img.shape}")
    h, w = img.shape[:2]
    raw = b"".join(b"\x00" + img[r].tobytes() for r in range(h))

    def chunk(kind: bytes, data: bytes) -> bytes:
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", w, h, bits, colour_type, 0, 0, 0)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))
    del channels


def colorize(values: np.ndarray, vmin: float | None = None, vmax: float | None = None,
             zero_black: bool = True) -> np.ndarray:
    """Maps (H, W) values to an (H, W, 3) uint8 false-colour image (blue -> green -> yellow -> red).

    Cells equal to 0 are drawn black when ``zero_black`` (missing depth, empty heightmap cells).
    """
    v = np.asarray(values, dtype=np.float64)
    finite = np.isfinite(v) & (v != 0 if zero_black else True)
    lo = np.min(v[finite]) if vmin is None and finite.any() else (vmin or 0.0)
    hi = np.max(v[finite]) if vmax is None and finite.any() else (vmax if vmax is not None else 1.0)
    t = np.clip((v - lo) / max(hi - lo, 1e-9), 0.0, 1.0)
    stops = np.array([[0.1, 0.2, 0.8], [0.1, 0.8, 0.3], [0.95, 0.9, 0.1], [0.9, 0.1, 0.1]])
    x = t * (len(stops) - 1)
    i = np.clip(np.floor(x).astype(int), 0, len(stops) - 2)
    f = (x - i)[..., None]
    rgb = stops[i] * (1 - f) + stops[i + 1] * f
    rgb[~finite] = 0.0
    return (rgb * 255 + 0.5).astype(np.uint8)


def tile(images: list[np.ndarray], cols: int, pad: int = 2) -> np.ndarray:
    """Lays same-sized (H, W, 3) uint8 images out on a grid with white padding."""
    if not images:
        raise ValueError("tile needs at least one image")
    h, w = images[0].shape[:2]
    rows = -(-len(images) // cols)
    out = np.full((rows * (h + pad) + pad, cols * (w + pad) + pad, 3), 255, np.uint8)
    for k, im in enumerate(images):
        r, c = divmod(k, cols)
        im = im if im.ndim == 3 else np.repeat(im[..., None], 3, axis=2)
        out[pad + r * (h + pad): pad + r * (h + pad) + h, pad + c * (w + pad): pad + c * (w + pad) + w] = im
    return out
