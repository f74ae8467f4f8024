"""Pictures of recorded VAGS attempts (``eval.py --record DIR``): numpy and the standard library.

One ``AttemptRecord`` holds what one world saw and decided in one attempt; ``attempt_picture``
draws it as a grid of panels and ``write_round`` writes a round's pictures and a JSON summary.

Panels (``attempt_picture``), in reading order, two rows of three:

1. the global colour heightmap, the executed grasp drawn as a line along its closing axis
   (a direct grasp: at the GDNet cell, angle ``rotation * pi / (n_rotations / 2)``, or
   ``rotation * pi / n_rotations`` with ``half_turn``; a grasp
   after a viewpoint move: at ``grasp_cell`` along ``yaw`` if given, else not drawn);
2. the global height map (false colour, black where empty);
3. GDNet's Q, max over rotations, with a cross at GDNet's argmax;
4. VANet's Q with a cross at the chosen viewpoint (grey when the policy has no VANet);
5. the raw close-view depth image (false colour, black where missing; grey for a direct grasp);
6. GG-CNN's quality map with a cross at its peak and a line along its angle (grey if none).

The picture's outer border is green for a successful grasp and red for a failed one.
Angles follow the project conventions: a heightmap angle theta is the closing axis along
``(cos theta, sin theta)`` in (col, row); a GG-CNN angle is the same in image (u, v) = (col, row).
"""
from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from typing import Any, Optional

import numpy as np

from vags_jax.benchmark.images import colorize, save_png, tile

SUCCESS_RGB = (0, 200, 0)
FAILURE_RGB = (220, 0, 0)
GREY_RGB = (128, 128, 128)
GRASP_RGB = (255, 0, 255)   # executed grasp, GG-CNN angle line
MARK_RGB = (255, 255, 255)  # argmax / viewpoint / peak crosses
BORDER_PX = 4


@dataclass(frozen=True, eq=False)
class AttemptRecord:
    """One recorded attempt of one world.  Arrays are numpy (jax arrays are converted).

    round_index, attempt_index: ints >= 0; n_objects: objects on the table at the round's start.
    color: (H, W, 3) uint8 global colour heightmap; height: (H, W) float32 metres.
    q_grasp: (H, W) float32 GDNet Q, max over rotations; grasp: (3,) int [rotation, row, col],
      GDNet's argmax; q_max: the gate's score (GDNet's largest Q for the "q" gate); threshold: the
      score above which VAGS grasps directly.
    direct: True when GDNet's grasp was executed directly (1 motion).
    success: the grasp's outcome; grasp_world: (3,) float32 executed grasp position (m);
      yaw: its closing-axis yaw (rad).
    q_view: (H, W) float32 VANet Q, or None; view: (2,) int [row, col] chosen viewpoint or None.
    local_depth: (h, w) float32 raw close-view depth (m, 0 = missing), or None (direct grasp).
    ggcnn_quality, ggcnn_angle, ggcnn_width: (S, S) float32 GG-CNN post-processed maps, or None;
      ggcnn_pixel: (2,) int [u, v] (u column, v row) of GG-CNN's peak in the S x S image, or
      None; ggcnn_angle_peak: the angle (rad) at the peak, or None.
    n_rotations: GDNet's rotation count (rotation r is angle r * pi / (n_rotations / 2)).
    half_turn: GDNet's rotations span half a turn (angle r * pi / n_rotations; ``config.Grasp``).
    grasp_cell: (2,) float [row, col] heightmap cell of the executed grasp, or None; used to draw
      a grasp made after a viewpoint move on the colour panel (a direct grasp is drawn at
      ``grasp[1:]``).
    """

    round_index: int
    attempt_index: int
    n_objects: int
    color: np.ndarray
    height: np.ndarray
    q_grasp: np.ndarray
    grasp: np.ndarray
    q_max: float
    threshold: float
    direct: bool
    success: bool
    grasp_world: np.ndarray
    yaw: float
    q_view: Optional[np.ndarray] = None
    view: Optional[np.ndarray] = None
    local_depth: Optional[np.ndarray] = None
    ggcnn_quality: Optional[np.ndarray] = None
    ggcnn_angle: Optional[np.ndarray] = None
    ggcnn_width: Optional[np.ndarray] = None
    ggcnn_pixel: Optional[np.ndarray] = None
    ggcnn_angle_peak: Optional[float] = None
    n_rotations: int = 16
    grasp_cell: Optional[np.ndarray] = None
    half_turn: bool = False

    def __post_init__(self):
        set_ = lambda name, value: object.__setattr__(self, name, value)  # noqa: E731
        for name in ("round_index", "attempt_index", "n_objects"):
            set_(name, _int(name, getattr(self, name), low=0))
        set_("n_rotations", _int("n_rotations", self.n_rotations, low=1))
        for name in ("direct", "success", "half_turn"):
            set_(name, _bool(name, getattr(self, name)))
        for name in ("q_max", "threshold", "yaw"):
            set_(name, _float(name, getattr(self, name)))

        color = np.asarray(self.color)
        if color.ndim != 3 or color.shape[2] != 3 or color.dtype != np.uint8 or color.size == 0:
            raise ValueError(f"AttemptRecord.color must be (H, W, 3) uint8, got {color.shape} {color.dtype}")
        set_("color", color)
        hw = color.shape[:2]
        set_("height", _float_map("height", self.height, hw))
        set_("q_grasp", _float_map("q_grasp", self.q_grasp, hw))
        set_("grasp", _index("grasp", self.grasp, 3, "[rotation, row, col]",
                             bounds=(self.n_rotations,) + hw))
        set_("grasp_world", _vector("grasp_world", self.grasp_world, 3))
        if self.q_view is not None:
            set_("q_view", _float_map("q_view", self.q_view, hw))
        if self.view is not None:
            set_("view", _index("view", self.view, 2, "[row, col]", bounds=hw))
        if self.grasp_cell is not None:
            set_("grasp_cell", _vector("grasp_cell", self.grasp_cell, 2))
        if self.local_depth is not None:
            set_("local_depth", _float_map("local_depth", self.local_depth, None))

        maps = ("ggcnn_quality", "ggcnn_angle", "ggcnn_width")
        given = [m for m in maps if getattr(self, m) is not None]
        if given and len(given) != 3:
            raise ValueError(f"AttemptRecord: give all of {maps} or none, got only {given}")
        s = None
        if given:
            q = _float_map("ggcnn_quality", self.ggcnn_quality, None)
            if q.shape[0] != q.shape[1]:
                raise ValueError(f"AttemptRecord.ggcnn_quality must be square (S, S) float, got {q.shape}")
            s = q.shape
            set_("ggcnn_quality", q)
            set_("ggcnn_angle", _float_map("ggcnn_angle", self.ggcnn_angle, s))
            set_("ggcnn_width", _float_map("ggcnn_width", self.ggcnn_width, s))
        if self.ggcnn_pixel is not None:
            # [u, v] = [col, row]: bounded by (S, S) when the maps are given.
            set_("ggcnn_pixel", _index("ggcnn_pixel", self.ggcnn_pixel, 2, "[u, v]",
                                       bounds=(s[1], s[0]) if s else None))
        if self.ggcnn_angle_peak is not None:
            set_("ggcnn_angle_peak", _float("ggcnn_angle_peak", self.ggcnn_angle_peak))

    def summary(self) -> dict:
        """JSON-safe dict of the attempt's scalars and small vectors (no numpy types)."""
        return {
            "attempt": self.attempt_index,
            "n_objects": self.n_objects,
            "direct": self.direct,
            "q_max": _json_float(self.q_max),
            "threshold": _json_float(self.threshold),
            "grasp": _json_list(self.grasp),
            "view": _json_list(self.view),
            "ggcnn_pixel": _json_list(self.ggcnn_pixel),
            "ggcnn_angle_peak": _json_float(self.ggcnn_angle_peak),
            "success": self.success,
            "grasp_world": _json_list(self.grasp_world),
            "yaw": _json_float(self.yaw),
        }


# ----------------------------------------------------------------------------- validation


def _where(name: str) -> str:
    return f"AttemptRecord.{name}"


def _int(name: str, value: Any, low: int) -> int:
    a = np.asarray(value)
    if a.shape != () or not np.issubdtype(a.dtype, np.integer):  # bools and floats are refused
        raise ValueError(f"{_where(name)} must be an int >= {low}, got {value!r}")
    value = int(a)
    if value < low:
        raise ValueError(f"{_where(name)} must be an int >= {low}, got {value}")
    return value


def _bool(name: str, value: Any) -> bool:
    a = np.asarray(value)
    if a.shape != () or a.dtype != np.bool_:
        raise ValueError(f"{_where(name)} must be a bool, got {value!r}")
    return bool(a)


def _float(name: str, value: Any) -> float:
    a = np.asarray(value)
    if a.shape != () or not (np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer)) \
            or a.dtype == np.bool_:
        raise ValueError(f"{_where(name)} must be a number, got {value!r}")
    return float(a)


def _float_map(name: str, value: Any, hw: Optional[tuple]) -> np.ndarray:
    a = np.asarray(value)
    want = "(H, W) float" if hw is None else f"{tuple(hw)} float (the heightmap's H, W)"
    if a.ndim != 2 or a.size == 0 or not np.issubdtype(a.dtype, np.floating) or (hw is not None and a.shape != tuple(hw)):
        raise ValueError(f"{_where(name)} must be {want}, got {a.shape} {a.dtype}")
    return a.astype(np.float32, copy=False)


def _vector(name: str, value: Any, n: int) -> np.ndarray:
    a = np.asarray(value)
    if a.shape != (n,) or not (np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer)) \
            or a.dtype == np.bool_:
        raise ValueError(f"{_where(name)} must be ({n},) float, got {a.shape} {a.dtype}")
    return a.astype(np.float32)


def _index(name: str, value: Any, n: int, meaning: str, bounds: Optional[tuple]) -> np.ndarray:
    a = np.asarray(value)
    if a.shape != (n,) or not np.issubdtype(a.dtype, np.integer):
        raise ValueError(f"{_where(name)} must be ({n},) int {meaning}, got {a.shape} {a.dtype}")
    a = a.astype(np.int64)
    if bounds is not None and (np.any(a < 0) or np.any(a >= np.asarray(bounds))):
        raise ValueError(f"{_where(name)} {meaning} = {a.tolist()} is out of range: each must be in "
                         f"0..bound-1 with bounds {list(bounds)}")
    return a


def _json_float(x: Optional[float]) -> Optional[float]:
    return None if x is None or not math.isfinite(x) else float(x)


def _json_list(a: Optional[np.ndarray]) -> Optional[list]:
    if a is None:
        return None
    return [int(v) if np.issubdtype(a.dtype, np.integer) else _json_float(float(v)) for v in a]


# ----------------------------------------------------------------------------- drawing


def _resize_nearest(img: np.ndarray, out_h: int, out_w: int) -> np.ndarray:
    """Nearest-neighbour resize of (h, w) or (h, w, C)."""
    h, w = img.shape[:2]
    rows = np.minimum((np.arange(out_h) * h) // out_h, h - 1)
    cols = np.minimum((np.arange(out_w) * w) // out_w, w - 1)
    return img[rows][:, cols]


class _Panel:
    """An (H, W, 3) uint8 panel holding a source image of shape (h, w), scaled to fit with its
    aspect ratio kept (grey bars elsewhere); draws markers given in source (row, col)."""

    def __init__(self, rgb: np.ndarray, size: tuple[int, int]):
        H, W = size
        h, w = rgb.shape[:2]
        self.scale = min(H / h, W / w)
        nh, nw = max(1, round(h * self.scale)), max(1, round(w * self.scale))
        self.r0, self.c0 = (H - nh) // 2, (W - nw) // 2
        self.img = np.full((H, W, 3), GREY_RGB, np.uint8)
        self.img[self.r0:self.r0 + nh, self.c0:self.c0 + nw] = _resize_nearest(rgb, nh, nw)

    def _to_panel(self, row: float, col: float) -> tuple[float, float]:
        # Centre of source cell (row, col) in panel pixel coordinates.
        return self.r0 + (row + 0.5) * self.scale - 0.5, self.c0 + (col + 0.5) * self.scale - 0.5

    def _dots(self, rr: np.ndarray, cc: np.ndarray, rgb, width: int) -> None:
        H, W = self.img.shape[:2]
        half = width // 2
        for dr in range(-half, half + 1):
            for dc in range(-half, half + 1):
                r = np.round(rr + dr).astype(int)
                c = np.round(cc + dc).astype(int)
                ok = (r >= 0) & (r < H) & (c >= 0) & (c < W)
                self.img[r[ok], c[ok]] = rgb

    def _segment(self, r0, c0, r1, c1, rgb) -> None:
        n = int(max(abs(r1 - r0), abs(c1 - c0))) * 2 + 2
        t = np.linspace(0.0, 1.0, n)
        rr, cc = r0 + t * (r1 - r0), c0 + t * (c1 - c0)
        self._dots(rr, cc, (0, 0, 0), 3)  # dark outline so the mark shows on any colour
        self._dots(rr, cc, rgb, 1)

    def cross(self, row: float, col: float, rgb=MARK_RGB) -> None:
        r, c = self._to_panel(row, col)
        L = max(3.0, 0.05 * max(self.img.shape[:2]))
        self._segment(r - L, c, r + L, c, rgb)
        self._segment(r, c - L, r, c + L, rgb)

    def axis_line(self, row: float, col: float, angle: float, rgb=GRASP_RGB) -> None:
        """A line through (row, col) along (cos angle, sin angle) in (col, row)."""
        r, c = self._to_panel(row, col)
        L = max(5.0, 0.1 * max(self.img.shape[:2]))
        dr, dc = L * math.sin(angle), L * math.cos(angle)
        self._segment(r - dr, c - dc, r + dr, c + dc, rgb)


def _grey(size: tuple[int, int]) -> np.ndarray:
    return np.full(size + (3,), GREY_RGB, np.uint8)


def panel_size(rec: AttemptRecord, min_px: int = 128) -> tuple[int, int]:
    """The common panel size: the heightmap's (H, W), enlarged by an integer factor until its
    longer side is at least ``min_px`` (so that markers stay readable on small heightmaps)."""
    H, W = rec.color.shape[:2]
    k = max(1, -(-min_px // max(H, W)))
    return H * k, W * k


def attempt_picture(rec: AttemptRecord, min_px: int = 128) -> np.ndarray:
    """The attempt as one (h, w, 3) uint8 picture: six panels (module docstring) on a 3 x 2
    grid, framed green (success) or red (failure)."""
    if not isinstance(rec, AttemptRecord):
        raise ValueError(f"attempt_picture needs an AttemptRecord, got {type(rec).__name__}")
    size = panel_size(rec, min_px)
    rot, row, col = (int(v) for v in rec.grasp)
    turn = math.pi if rec.half_turn else 2.0 * math.pi
    rotation_angle = rot * turn / rec.n_rotations if rec.n_rotations > 1 else 0.0

    colour = _Panel(rec.color, size)
    if rec.direct:
        colour.axis_line(row, col, rotation_angle)
    elif rec.grasp_cell is not None:
        colour.axis_line(float(rec.grasp_cell[0]), float(rec.grasp_cell[1]), rec.yaw)

    height = _Panel(colorize(rec.height), size)

    gdnet = _Panel(colorize(rec.q_grasp, zero_black=False), size)
    gdnet.cross(row, col)

    if rec.q_view is not None:
        vanet = _Panel(colorize(rec.q_view, zero_black=False), size)
        if rec.view is not None:
            vanet.cross(int(rec.view[0]), int(rec.view[1]))
        vanet = vanet.img
    else:
        vanet = _grey(size)

    depth = _Panel(colorize(rec.local_depth), size).img if rec.local_depth is not None else _grey(size)

    if rec.ggcnn_quality is not None:
        gg = _Panel(colorize(rec.ggcnn_quality, zero_black=False), size)
        if rec.ggcnn_pixel is not None:
            u, v = int(rec.ggcnn_pixel[0]), int(rec.ggcnn_pixel[1])
            angle = rec.ggcnn_angle_peak if rec.ggcnn_angle_peak is not None else float(rec.ggcnn_angle[v, u])
            gg.axis_line(v, u, angle)
            gg.cross(v, u)
        gg = gg.img
    else:
        gg = _grey(size)

    out = tile([colour.img, height.img, gdnet.img, vanet, depth, gg], cols=3, pad=BORDER_PX)
    outcome = SUCCESS_RGB if rec.success else FAILURE_RGB
    out[:BORDER_PX] = outcome
    out[-BORDER_PX:] = outcome
    out[:, :BORDER_PX] = outcome
    out[:, -BORDER_PX:] = outcome
    return out


# ----------------------------------------------------------------------------- files


def write_round(directory: str, records: list[AttemptRecord]) -> list[str]:
    """Writes ``round{r:03d}_attempt{a:02d}.png`` per record and one ``round{r:03d}.json`` per
    round found in ``records`` (``{"round": r, "attempts": [AttemptRecord.summary(), ...]}``,
    attempts in order).  Give all of a round's attempts in one call: its JSON is rewritten.
    Creates ``directory``.  Returns the written paths (pictures, then JSON files)."""
    if not isinstance(records, (list, tuple)) or not records:
        raise ValueError("write_round needs a non-empty list of AttemptRecord")
    for i, rec in enumerate(records):
        if not isinstance(rec, AttemptRecord):
            raise ValueError(f"write_round: records[{i}] must be an AttemptRecord, got {type(rec).__name__}")
    seen = set()
    for rec in records:
        key = (rec.round_index, rec.attempt_index)
        if key in seen:
            raise ValueError(f"write_round: round {key[0]} attempt {key[1]} appears twice (its picture "
                             f"would be overwritten)")
        seen.add(key)
    os.makedirs(directory, exist_ok=True)
    paths = []
    by_round: dict[int, list[AttemptRecord]] = {}
    for rec in records:
        path = os.path.join(directory, f"round{rec.round_index:03d}_attempt{rec.attempt_index:02d}.png")
        save_png(path, attempt_picture(rec))
        paths.append(path)
        by_round.setdefault(rec.round_index, []).append(rec)
    for r, recs in sorted(by_round.items()):
        path = os.path.join(directory, f"round{r:03d}.json")
        recs = sorted(recs, key=lambda x: x.attempt_index)
        with open(path, "w") as f:
            json.dump({"round": r, "attempts": [x.summary() for x in recs]}, f, indent=1, allow_nan=False)
        paths.append(path)
    return paths


__all__ = ["AttemptRecord", "attempt_picture", "write_round", "panel_size"]
