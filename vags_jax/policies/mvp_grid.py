"""Multi-View Picking's grid (Morrison et al. 2019), as pure functions on arrays.

The workspace is cut into an N x N grid of cells (row along +y, column along +x, as the
heightmaps; ``grid_size``).  Per world and cell, ``ViewGrid`` keeps what GG-CNN said about the
cell over every view of an attempt:

* ``qhist`` (B, N, N, Q): how many pixel observations fell in each of Q quality bins, every
  bin starting at 1 (MVP's prior);
* ``avote`` (B, N, N, A): per angle bin (A bins over [-pi/2, pi/2)), the sum of the observed
  qualities (bin centres) of the observations with that angle;
* ``count`` (B, N, N): observations; ``zsum`` (B, N, N): the sum of their surface heights (m).

MVP keeps a full angle x quality histogram per cell; it only ever reads its marginal over
angles (the quality histogram) and its quality-weighted angle counts, which are the two
arrays kept here, so the results are the same with 28 instead of 180 values per cell.

From the grid: the count-weighted mean quality less the failure map (``mean_quality``), the
best grasp (``best_grasp``: its argmax, refined over the 3 x 3 neighbours), the entropy of
each cell's quality histogram (``entropy``), blurred by the camera's footprint
(``blur``, ``footprint_sigma``) into the information gain, the height-weighted distance cost
(``travel_cost``) and the next view (``next_position``).  ``add_failure`` adds a failed grasp
to the failure map (B, N, N).
"""
from __future__ import annotations

import math

import jax
import jax.numpy as jnp
from flax import struct

from vags_jax.config import Mvp, Workspace


@struct.dataclass
class ViewGrid:
    """What the views of one attempt said, per world and cell (module docstring for shapes)."""

    qhist: jax.Array
    avote: jax.Array
    count: jax.Array
    zsum: jax.Array


def grid_size(ws: Workspace, mcfg: Mvp) -> int:
    """Cells per side: the workspace cut into cells of about ``mvp.cell`` (at least 3)."""
    return max(3, int(round(ws.size / mcfg.cell)))


def init_grid(n_worlds: int, n: int, mcfg: Mvp) -> ViewGrid:
    """An empty grid: every quality bin at 1 (the prior), no votes, no observations."""
    B, Q, A = n_worlds, mcfg.quality_bins, mcfg.angle_bins
    z = jnp.zeros((B, n, n), jnp.float32)
    return ViewGrid(qhist=jnp.ones((B, n, n, Q), jnp.float32), avote=jnp.zeros((B, n, n, A), jnp.float32),
                    count=z, zsum=z)


def cell_centres(ws: Workspace, n: int) -> jax.Array:
    """(N, N, 2) world [x, y] of every cell centre (row along +y, column along +x)."""
    cell = ws.size / n
    lo = jnp.asarray(ws.center[:2], jnp.float32) - ws.size / 2
    idx = (jnp.arange(n, dtype=jnp.float32) + 0.5) * cell
    x = lo[0] + idx[None, :].repeat(n, 0)
    y = lo[1] + idx[:, None].repeat(n, 1)
    return jnp.stack([x, y], axis=-1)


def world_to_cell(xy: jax.Array, ws: Workspace, n: int):
    """World (..., 2) [x, y] -> ((..., 2) int32 [row, col] clipped into the grid, (...,) bool inside)."""
    lo = jnp.asarray(ws.center[:2], jnp.float32) - ws.size / 2
    rc = jnp.floor((xy[..., ::-1] - lo[::-1]) / (ws.size / n)).astype(jnp.int32)
    inside = ((rc >= 0) & (rc < n)).all(-1)
    return jnp.clip(rc, 0, n - 1), inside


def bin_centres(bins: int) -> jax.Array:
    """(bins,) centres of equal bins over [0, 1]: 0.5 / bins, 1.5 / bins, ..."""
    return (jnp.arange(bins, dtype=jnp.float32) + 0.5) / bins


def angle_centres(bins: int) -> jax.Array:
    """(bins,) centres of equal bins over the closing-axis yaw range [-pi/2, pi/2)."""
    return -math.pi / 2 + bin_centres(bins) * math.pi


def add_observations(grid: ViewGrid, xyz: jax.Array, quality: jax.Array, yaw: jax.Array, valid: jax.Array,
                     ws: Workspace) -> ViewGrid:
    """Counts P pixel observations per world into the grid: xyz (B, P, 3) their surface points,
    quality (B, P) GG-CNN's quality (clipped into [0, 1]), yaw (B, P) closing-axis yaw (rad),
    valid (B, P) bool (observations to count; points outside the grid never count)."""
    B, n, _, Q = grid.qhist.shape
    A = grid.avote.shape[-1]
    rc, inside = world_to_cell(xyz[..., :2], ws, n)
    w = (valid & inside).astype(jnp.float32)  # (B, P)
    cell = rc[..., 0] * n + rc[..., 1]
    q = jnp.clip(quality, 0.0, 1.0)
    qbin = jnp.clip(jnp.floor(q * Q).astype(jnp.int32), 0, Q - 1)
    a = jnp.mod(yaw + math.pi / 2, math.pi) / math.pi  # [0, 1)
    abin = jnp.clip(jnp.floor(a * A).astype(jnp.int32), 0, A - 1)
    qc = bin_centres(Q)[qbin]

    def one(cell, qbin, abin, w, qc, z):
        qh = jax.ops.segment_sum(w, cell * Q + qbin, n * n * Q)
        av = jax.ops.segment_sum(w * qc, cell * A + abin, n * n * A)
        ct = jax.ops.segment_sum(w, cell, n * n)
        zs = jax.ops.segment_sum(w * z, cell, n * n)
        return qh.reshape(n, n, Q), av.reshape(n, n, A), ct.reshape(n, n), zs.reshape(n, n)

    qh, av, ct, zs = jax.vmap(one)(cell, qbin, abin, w, qc, xyz[..., 2])
    return ViewGrid(qhist=grid.qhist + qh, avote=grid.avote + av, count=grid.count + ct, zsum=grid.zsum + zs)


def entropy(qhist: jax.Array) -> jax.Array:
    """(..., Q) quality histogram (counts > 0) -> (...,) entropy (nats) of its distribution."""
    p = qhist / qhist.sum(-1, keepdims=True)
    return -(p * jnp.log(jnp.maximum(p, 1e-12))).sum(-1)


def mean_quality(grid: ViewGrid, failures: jax.Array) -> jax.Array:
    """(B, N, N) MVP's grasp score: the count-weighted mean quality of each cell's histogram
    (bin centres, the prior counts included), 0 where nothing was seen and on the grid's
    border, less the failure map (B, N, N), clipped into [0, 1]."""
    w = bin_centres(grid.qhist.shape[-1])
    m = (grid.qhist * w).sum(-1) / grid.qhist.sum(-1)
    n = m.shape[-1]
    inner = jnp.zeros((n, n), bool).at[1:-1, 1:-1].set(True)
    m = jnp.where((grid.count > 0) & inner, m, 0.0)
    return jnp.clip(m - failures, 0.0, 1.0)


def best_grasp(grid: ViewGrid, failures: jax.Array, ws: Workspace):
    """MVP's best fused grasp per world -> (xy (B, 2) world, surface z (B,) the mean observed
    height of the best cell, yaw (B,) closing axis, score (B,) its mean quality).

    The best cell is the argmax of ``mean_quality``; its position is the score-weighted mean of
    the centres of its 3 x 3 neighbours (the cell itself when they all score 0); its angle the
    circular mean of 2 yaw over the neighbours' angle votes, each neighbour weighted by its
    score (axial data: yaw and yaw + pi are one grasp)."""
    m = mean_quality(grid, failures)
    B, n, _ = m.shape
    flat = jnp.argmax(m.reshape(B, -1), axis=1)
    r, c = flat // n, flat % n
    off = jnp.array([(i, j) for i in (-1, 0, 1) for j in (-1, 0, 1)], jnp.int32)  # (9, 2)
    nb = jnp.clip(jnp.stack([r, c], -1)[:, None, :] + off[None], 0, n - 1)  # (B, 9, 2)
    b = jnp.arange(B)[:, None]
    w = m[b, nb[..., 0], nb[..., 1]]  # (B, 9)
    centres = cell_centres(ws, n)[nb[..., 0], nb[..., 1]]  # (B, 9, 2)
    own = cell_centres(ws, n)[r, c]
    wsum = w.sum(1, keepdims=True)
    xy = jnp.where(wsum > 0, (w[..., None] * centres).sum(1) / jnp.maximum(wsum, 1e-12), own)
    votes = grid.avote[b, nb[..., 0], nb[..., 1]] * w[..., None]  # (B, 9, A)
    two = 2.0 * angle_centres(grid.avote.shape[-1])
    yaw = 0.5 * jnp.arctan2((votes * jnp.sin(two)).sum((1, 2)), (votes * jnp.cos(two)).sum((1, 2)))
    yaw = jnp.mod(yaw + math.pi / 2, math.pi) - math.pi / 2
    bi = jnp.arange(B)
    z = grid.zsum[bi, r, c] / jnp.maximum(grid.count[bi, r, c], 1.0)
    return xy, z, yaw, m[bi, r, c]


def blur(x: jax.Array, sigma: jax.Array) -> jax.Array:
    """(B, N, N) maps, each blurred by a Gaussian of its own sigma (B,) in cells, truncated at 3
    sigma, normalised to sum 1 over the full kernel, zero outside the grid (a cell near the
    border gains less)."""
    n = x.shape[-1]
    d = jnp.arange(n, dtype=jnp.float32)
    s = jnp.maximum(sigma, 1e-3)[:, None, None]
    diff = d[None, :, None] - d[None, None, :]
    k = jnp.where(jnp.abs(diff) <= 3 * s, jnp.exp(-0.5 * (diff / s) ** 2), 0.0)  # (B, N, N)
    full = jnp.arange(-n + 1, n, dtype=jnp.float32)[None, :]
    z = jnp.where(jnp.abs(full) <= 3 * s[:, :, 0], jnp.exp(-0.5 * (full / s[:, :, 0]) ** 2), 0.0).sum(1)
    g = k / z[:, None, None]
    return jnp.einsum("bij,bjk,blk->bil", g, x, g)


def footprint_sigma(z_cam: jax.Array, view_width: float, cell: float) -> jax.Array:
    """MVP's blur: the camera's footprint in cells / 6.  z_cam (B,) camera height above the
    table (m); view_width: the footprint's width per metre of height (GG-CNN's crop in
    pixels / fx); cell (m)."""
    return z_cam * view_width / cell / 6.0


def travel_cost(centres: jax.Array, best_xy: jax.Array, z_cam: jax.Array, mcfg: Mvp) -> jax.Array:
    """(B, N, N) MVP's cost of a view above each cell: its distance to the best grasp (B, 2) /
    ``best_scale`` * (1 - h) * ``best_gain``, h = clip((z_cam - stop) / (start - stop), 0, 1):
    free at the top, and pulling towards the best grasp as the camera descends.  centres
    (N, N, 2), z_cam (B,) m above the table."""
    h = jnp.clip((z_cam - mcfg.stop_height) / (mcfg.start_height - mcfg.stop_height), 0.0, 1.0)
    dist = jnp.linalg.norm(centres[None] - best_xy[:, None, None, :], axis=-1)
    return dist / mcfg.best_scale * (1.0 - h)[:, None, None] * mcfg.best_gain


def next_position(value: jax.Array, centres: jax.Array, position: jax.Array, mcfg: Mvp, ws: Workspace):
    """MVP's greedy step -> the next camera position (B, 3) (z above the table frame's origin as
    ``position``).  value (B, N, N) gain - cost; position (B, 3) the camera.  The target is the
    best cell within ``greedy_window`` of the camera's xy (its own cell when none is); the
    lateral part of the unit step is (target - camera) / window, at most sqrt(1 -
    min_descent^2) long, and the rest of the unit length goes down, so every step descends at
    least ``step * min_descent``."""
    B, n, _ = value.shape
    dist = jnp.linalg.norm(centres[None] - position[:, None, None, :2], axis=-1)
    own, _ = world_to_cell(position[:, :2], ws, n)
    at_own = ((jnp.arange(n)[None, :, None] == own[:, 0, None, None])
              & (jnp.arange(n)[None, None, :] == own[:, 1, None, None]))
    near = (dist <= mcfg.greedy_window) | at_own
    flat = jnp.argmax(jnp.where(near, value, -jnp.inf).reshape(B, -1), axis=1)
    target = centres.reshape(-1, 2)[flat]
    lateral = (target - position[:, :2]) / mcfg.greedy_window
    most = math.sqrt(max(0.0, 1.0 - mcfg.min_descent ** 2))
    norm = jnp.linalg.norm(lateral, axis=1, keepdims=True)
    lateral = lateral * jnp.minimum(1.0, most / jnp.maximum(norm, 1e-12))
    down = jnp.sqrt(jnp.maximum(1.0 - (lateral ** 2).sum(1), 0.0))
    return position + mcfg.step * jnp.concatenate([lateral, -down[:, None]], axis=1)


def add_failure(failures: jax.Array, xy: jax.Array, failed: jax.Array, ws: Workspace, sigma: float) -> jax.Array:
    """The failure map (B, N, N) plus, where failed (B,) is set, a Gaussian of height 1 and
    ``sigma`` m centred at xy (B, 2)."""
    n = failures.shape[-1]
    d2 = ((cell_centres(ws, n)[None] - xy[:, None, None, :]) ** 2).sum(-1)
    blob = jnp.exp(-0.5 * d2 / max(sigma, 1e-6) ** 2)
    return failures + jnp.where(failed[:, None, None], blob, 0.0)


__all__ = ["ViewGrid", "grid_size", "init_grid", "cell_centres", "world_to_cell", "bin_centres", "angle_centres",
           "add_observations", "entropy", "mean_quality", "best_grasp", "blur", "footprint_sigma", "travel_cost",
           "next_position", "add_failure"]
