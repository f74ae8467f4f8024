"""The "rate" gate (``vags.gate="rate"``): move the camera where a move raises the picks per
hour, by a table measured on the trained run (``vags_jax.stages.gate_measure``).

The table bins the success net's raw estimate p_direct (at GDNet's argmax) into K quantile
bins.  Per bin it holds the success of the direct grasp and of the grasp after a move and the
modelled robot seconds a move adds, all measured by executing both branches from the same
states.  ``rate`` is the picks per second of the best choice per bin (Dinkelbach's iteration
on the ratio of expected picks to expected seconds), and a bin's move value is
``moved - direct - rate * extra_seconds``: a move pays where it is positive.  Unlike the
"success" gate, the comparison needs no bias correction and no fixed move cost: both branches
are measured on every state, and the motion's cost is its time at the rate the gate achieves.
The table also holds the objects each branch knocks off the table (``lost_*``, ``paired_lost``).
By default they are reported beside the decision; with ``count_lost`` (``gate_table.count_lost``)
each one counts as a pick lost, so the gate maximises net picks per second (picks minus objects
knocked off) and a move must also pay for the objects it knocks off.

``vags.gate_min_z`` keeps, when the table is loaded, only the moves its states show to pay
(``significant``): a bin whose move value is positive but within that many standard errors of 0
grasps directly, so the table's noise no longer decides whether the gate moves there.

``vags.max_motion_number`` caps the moves when the table is loaded (``capped``): moving bins are
dropped, the smallest success gain first, until the motion number the table predicts is at most
the cap (the issue's goal is a motion number below 1.35; picks per hour alone may move more).
Whole bins are coarse (eighths of the states: one bin fewer can fall far below the cap), so with
the states the table was measured on (``STATES_FILE`` beside gate.json) the moving bins are taken
by success gain and the next one is split, its lowest-p_direct states moving as far as the cap
allows (``split_capped``; ``vags.cap_split``).

Stored as ``RUN/gate.json`` (``save`` / ``load``); ``GateTable.array()`` is the (2, K) array the
jitted decision reads (``move_value``).
"""
from __future__ import annotations

import dataclasses
import json
import os
from typing import Optional

import jax
import jax.numpy as jnp
import numpy as np

GATE_FILE = "gate.json"
STATES_FILE = "gate_states.npz"  # the per-state rows a table was fit on (stages.gate_measure)


@dataclasses.dataclass(frozen=True)
class GateTable:
    """Per bin k of p_direct (K bins, ``edges`` (K-1,) between them): ``states`` counted,
    success of the ``direct`` grasp and of the grasp after a move (``moved``), the modelled
    seconds a move adds (``extra_seconds``, moved minus direct), and ``move_value`` =
    moved - direct - rate * extra_seconds; ``rate``: picks per second of the best gate;
    ``lost_direct`` / ``lost_moved``: objects per attempt that left the table without a grasp
    on each branch (empty in tables measured before they were recorded); ``count_lost``: the
    rate and move values count each as a pick lost; ``move_value_se``: each bin's standard error
    of ``move_value`` over its states, the rate held fixed (0 for a bin of one state; empty in
    tables measured before it was recorded), so that a bin whose choice is within the noise of
    its states can be told (``close_bins``)."""

    edges: tuple
    states: tuple
    direct: tuple
    moved: tuple
    extra_seconds: tuple
    rate: float
    move_value: tuple
    lost_direct: tuple = ()
    lost_moved: tuple = ()
    count_lost: bool = False
    move_value_se: tuple = ()

    def array(self) -> np.ndarray:
        """(2, K) float32: row 0 the bins' upper edges (the last +inf), row 1 ``move_value``."""
        return np.stack([np.append(np.asarray(self.edges, np.float32), np.inf),
                         np.asarray(self.move_value, np.float32)]).astype(np.float32)


def best_rate(n, s_d, t_d, s_m, t_m, iterations: int = 50):
    """Dinkelbach's iteration for the choice per bin that maximises expected picks over expected
    seconds: n (K,) states, s_* success and t_* seconds (K,) of the direct and moved branches
    -> (rate, move (K,) bool).  Each step moves exactly the bins whose extra success beats the
    current rate times their extra seconds; the rate never falls and the choices are finitely
    many, so it stops at the optimum."""
    n, s_d, t_d, s_m, t_m = (np.asarray(x, np.float64) for x in (n, s_d, t_d, s_m, t_m))
    move = np.zeros(n.shape, bool)
    rate = float(np.sum(n * s_d) / np.sum(n * t_d))
    for _ in range(iterations):
        new = (s_m - s_d) - rate * (t_m - t_d) > 0
        new_rate = float(np.sum(n * np.where(new, s_m, s_d)) / np.sum(n * np.where(new, t_m, t_d)))
        if np.array_equal(new, move) or new_rate <= rate + 1e-12:
            break
        move, rate = new, new_rate
    return rate, move


def fit(p, s_d, t_d, s_m, t_m, n_bins: int, lost_direct=None, lost_moved=None, count_lost: bool = False) -> GateTable:
    """Per-state (N,) arrays -> ``GateTable`` over ``n_bins`` quantile bins of p (bins that
    would be empty are merged, so ties in p give fewer bins); ``lost_*`` (N,) objects each
    branch knocked off (optional; ``count_lost``: each counts as a pick lost)."""
    if count_lost and lost_direct is None:
        raise ValueError("count_lost needs the objects each branch knocked off (lost_direct, lost_moved)")
    p = np.asarray(p, np.float64)
    if n_bins < 1 or p.size < n_bins:
        raise ValueError(f"the gate table needs at least one state per bin: {p.size} states for {n_bins} bins")
    edges = np.unique(np.quantile(p, np.linspace(0, 1, n_bins + 1)[1:-1]))
    used = np.unique(np.searchsorted(edges, p, side="right"))
    edges = edges[used[1:] - 1]  # the lower edge of every non-empty bin but the first
    k = np.searchsorted(edges, p, side="right")
    n = np.bincount(k, minlength=edges.size + 1)  # every bin holds at least one state
    per = lambda x: np.bincount(k, weights=np.asarray(x, np.float64), minlength=n.size) / n  # noqa: E731
    sd, td, sm, tm = per(s_d), per(t_d), per(s_m), per(t_m)
    gd, gm = (sd - per(lost_direct), sm - per(lost_moved)) if count_lost else (sd, sm)  # picks counted per attempt
    rate, _ = best_rate(n, gd, td, gm, tm)
    f = lambda x: tuple(float(v) for v in x)  # noqa: E731
    lost = {} if lost_direct is None else {"lost_direct": f(per(lost_direct)), "lost_moved": f(per(lost_moved)),
                                           "count_lost": bool(count_lost)}
    value = (gm - gd) - rate * (tm - td)
    per_state = state_move_values(s_d, t_d, s_m, t_m, rate, lost_direct if count_lost else None, lost_moved)
    squares = np.bincount(k, weights=(per_state - value[k]) ** 2, minlength=n.size)
    se = np.where(n > 1, np.sqrt(squares / np.maximum(n - 1, 1) / n), 0.0)
    return GateTable(edges=f(edges), states=tuple(int(v) for v in n), direct=f(sd), moved=f(sm),
                     extra_seconds=f(tm - td), rate=float(rate), move_value=f(value), move_value_se=f(se), **lost)


def state_move_values(s_d, t_d, s_m, t_m, rate: float, lost_direct=None, lost_moved=None) -> np.ndarray:
    """Each state's move value (N,) as a bin's is of its means: moved - direct success, less the
    objects each branch knocked off where ``lost_direct`` is given (``count_lost``), less ``rate``
    times the seconds a move adds."""
    f = lambda x: np.asarray(x, np.float64)  # noqa: E731
    gain = f(s_m) - f(s_d)
    if lost_direct is not None:
        gain = gain - (f(lost_moved) - f(lost_direct))
    return gain - rate * (f(t_m) - f(t_d))


def close_bins(table: GateTable, z: float = 2.0) -> list:
    """Bins whose move value is within ``z`` standard errors of 0: their states cannot tell
    whether a move pays there, so another measurement could choose them the other way.  Empty
    for tables without ``move_value_se``."""
    if not table.move_value_se:
        return []
    v, se = np.abs(np.asarray(table.move_value, np.float64)), np.asarray(table.move_value_se, np.float64)
    return [int(k) for k in np.flatnonzero(v < z * se)]


def close_moving_bins(table: GateTable, z: float = 2.0) -> list:
    """The bins of ``close_bins`` the table moves in (move value > 0): those ``gate_min_z`` = z
    turns to direct grasps."""
    return [k for k in close_bins(table, z) if table.move_value[k] > 0]


class NoStandardErrors(ValueError):
    """A table without its bins' standard errors (measured before they were recorded), asked for
    ``significant`` moves."""


def significant(table: GateTable, min_z: float) -> GateTable:
    """``table`` with the moves its states do not show to pay dropped: a bin whose move value is
    positive but within ``min_z`` of its standard errors of 0 (``move_value_se``; the positive
    bins of ``close_bins(table, min_z)``) grasps directly, its value negated as ``capped`` drops
    a bin (0: the table as it is).  A bin of one state (error 0) keeps its choice.  Raises
    ``NoStandardErrors`` for a table without errors and ``min_z`` > 0."""
    if min_z <= 0:
        return table
    if not table.move_value_se:
        raise NoStandardErrors("this run's gate table has no standard errors (it was measured before they were "
                               "recorded), so vags.gate_min_z cannot tell which moves are within its noise: measure "
                               "it again with python -m vags_jax.stages.gate_measure --run RUN, or drop "
                               "vags.gate_min_z")
    drop = set(close_moving_bins(table, min_z))
    return dataclasses.replace(table, move_value=tuple(-float(v) if k in drop else float(v)
                                                       for k, v in enumerate(table.move_value)))


def motion_number(table: GateTable, moves) -> float:
    """The motion number the table predicts when the bins ``moves`` (K,) bool move: motions per
    grasped object over its states (a direct grasp one motion, a move and a grasp two); inf
    where no state the table plays that way succeeded."""
    n, moves = np.asarray(table.states, np.float64), np.asarray(moves, bool)
    grasped = float(np.sum(n * np.where(moves, table.moved, table.direct)))
    return float(np.sum(n * (1.0 + moves)) / grasped) if grasped > 0 else float("inf")


def motion_number_text(value: Optional[float]) -> str:
    """``moves_summary``'s motion number for a table: "-" where none is defined (no success)."""
    return "-" if value is None else f"{value:.3f}"


def capped(table: GateTable, max_motion_number: float) -> GateTable:
    """``table`` with moving bins (move value > 0) dropped, the smallest success gain (moved -
    direct) first, until ``motion_number`` is at most ``max_motion_number`` (0: no cap); a
    dropped bin's move value is negated (the decision moves only where a bin's value is positive:
    ``decision.gate_score``), keeping its size for the record.  Dropping by success gain keeps
    the most success per motion given up; the rate and the other bins are unchanged."""
    if max_motion_number <= 0:
        return table
    value = np.asarray(table.move_value, np.float64)
    moves = value > 0
    gain = np.asarray(table.moved, np.float64) - np.asarray(table.direct, np.float64)
    for k in sorted(np.flatnonzero(moves), key=lambda i: gain[i]):
        if motion_number(table, moves) <= max_motion_number:
            break
        moves[k] = False
    kept = np.where(moves | (value <= 0), value, -value)
    return dataclasses.replace(table, move_value=tuple(float(v) for v in kept))


def _bin_means(states: dict, mask: np.ndarray, rate: float, count_lost: bool) -> dict:
    """One bin's fields (as ``fit`` computes them) over the states ``mask`` (N,) bool selects."""
    mean = lambda k: float(np.mean(np.asarray(states[k], np.float64)[mask]))  # noqa: E731
    sd, sm = mean("direct_success"), mean("moved_success")
    extra = mean("moved_seconds") - mean("direct_seconds")
    out = {"states": int(np.sum(mask)), "direct": sd, "moved": sm, "extra_seconds": extra}
    if "direct_lost" in states:
        out["lost_direct"], out["lost_moved"] = mean("direct_lost"), mean("moved_lost")
    gd, gm = (sd - out["lost_direct"], sm - out["lost_moved"]) if count_lost else (sd, sm)
    out["move_value"] = (gm - gd) - rate * extra
    col = lambda k: np.asarray(states[k], np.float64)[mask]  # noqa: E731
    per_state = state_move_values(col("direct_success"), col("direct_seconds"), col("moved_success"),
                                  col("moved_seconds"), rate, *((col("direct_lost"), col("moved_lost"))
                                                                if count_lost else ()))
    n = per_state.size
    out["move_value_se"] = float(np.std(per_state, ddof=1) / np.sqrt(n)) if n > 1 else 0.0
    return out


def states_match(table: GateTable, states: Optional[dict]) -> bool:
    """Whether ``states`` (``STATES_FILE``'s arrays) are the states ``table`` was fit on: its
    p_direct fall into the table's bins in the table's counts."""
    if states is None or "p_direct" not in states:
        return False
    p = np.asarray(states["p_direct"], np.float64)
    k = np.searchsorted(np.asarray(table.edges, np.float64), p, side="right")
    return bool(np.array_equal(np.bincount(k, minlength=len(table.states)), np.asarray(table.states)))


def split_capped(table: GateTable, states: dict, max_motion_number: float) -> GateTable:
    """``capped`` at the grain of single states: the moving bins are taken in order of success
    gain (largest first, the reverse of the order ``capped`` drops them), the first i of them
    whole and the m lowest-p_direct states of the next one, with m as large as keeps the
    predicted ``motion_number`` at most the cap and those states' move value positive, and i as
    large as allows such an m.  Moving as many states as the cap allows, rather than the ones
    whose single measured outcomes gained, keeps the cut from chasing those outcomes' noise.
    A split bin becomes two, with its states' means (``states``: ``STATES_FILE``'s (N,) arrays,
    which ``states_match`` the table), the upper part's move value negated like a dropped
    bin's.  Returns ``capped``'s table where the cap drops nothing, the states lack a column the
    split needs (the objects knocked off, for a table that records them), or no split moves more
    than its whole bins; else a table of K + 1 bins, the rate unchanged."""
    whole = capped(table, max_motion_number)
    value = np.asarray(table.move_value, np.float64)
    need = ("p_direct", "direct_success", "moved_success", "direct_seconds", "moved_seconds") + (
        ("direct_lost", "moved_lost") if (table.lost_direct or table.count_lost) else ())
    if (max_motion_number <= 0 or np.array_equal(np.asarray(whole.move_value, np.float64), value)
            or any(k not in states for k in need)):
        return whole
    moved, direct = np.asarray(table.moved, np.float64), np.asarray(table.direct, np.float64)
    n = np.asarray(table.states, np.float64)
    order = sorted(np.flatnonzero(value > 0), key=lambda b: -(moved - direct)[b])
    edges = np.asarray(table.edges, np.float64)
    p = np.asarray(states["p_direct"], np.float64)
    bin_of = np.searchsorted(edges, p, side="right")
    col = {key: np.asarray(states[key], np.float64) for key in
           ("direct_success", "moved_success", "direct_seconds", "moved_seconds")}
    if table.count_lost:
        col["direct_lost"], col["moved_lost"] = (np.asarray(states[k], np.float64) for k in ("direct_lost", "moved_lost"))
    best = None  # (i, k, cut) of the largest i with a split under the cap
    for i, k in enumerate(order):
        base = np.isin(np.arange(n.size), order[:i])
        idx = np.flatnonzero(bin_of == k)
        idx = idx[np.argsort(p[idx], kind="stable")]
        ps, gain = p[idx], col["moved_success"][idx] - col["direct_success"][idx]
        net = gain - (col["moved_lost"][idx] - col["direct_lost"][idx] if table.count_lost else 0.0)
        worth = np.cumsum(net - table.rate * (col["moved_seconds"][idx] - col["direct_seconds"][idx])) > 0
        grasped = np.sum(n * np.where(base, moved, direct)) + np.cumsum(gain)
        motions = np.sum(n * (1.0 + base)) + np.arange(1, ps.size + 1)
        cut_ok = np.append(ps[:-1] < ps[1:], False)  # a cut between distinct values keeps exactly m below it
        ok = (motions / np.maximum(grasped, 1e-12) <= max_motion_number) & worth & cut_ok
        if ok.any():
            m = int(np.flatnonzero(ok)[-1])  # index of the last state moved
            best = (i, k, float(ps[m + 1]))
    if best is None or best[0] < int(np.sum(np.asarray(whole.move_value) > 0)):
        return whole  # a split would move fewer bins than capped's whole ones
    i, k, cut = best
    moving = set(int(b) for b in order[:i])
    value_now = tuple(float(v) if (v <= 0 or b in moving) else -float(v) for b, v in enumerate(value))
    table_now = dataclasses.replace(table, move_value=value_now)
    in_k = bin_of == k
    parts = [_bin_means(states, in_k & (p < cut), table.rate, table.count_lost),
             _bin_means(states, in_k & (p >= cut), table.rate, table.count_lost)]
    parts[1]["move_value"] = -abs(parts[1]["move_value"])
    names = ["states", "direct", "moved", "extra_seconds", "move_value"] + (["lost_direct", "lost_moved"]
                                                                           if table.lost_direct else []) + (
        ["move_value_se"] if table.move_value_se else [])
    fields = {}
    for name in names:
        old = list(getattr(table_now, name))
        fields[name] = tuple(old[:k] + [type(old[k])(parts[0][name]), type(old[k])(parts[1][name])] + old[k + 1:])
    return dataclasses.replace(table_now, edges=tuple(float(e) for e in np.insert(edges, k, cut)), **fields)


def read_states(run_dir: str) -> Optional[dict]:
    """RUN/``STATES_FILE``'s arrays, or None when the run has none."""
    path = os.path.join(run_dir, STATES_FILE)
    if not os.path.isfile(path):
        return None
    with np.load(path) as f:
        return {k: f[k] for k in f.files}


def moves_summary(table: GateTable, max_motion_number: float = 0.0, min_z: float = 0.0) -> dict:
    """What the decision plays from ``table`` (already ``significant`` and ``capped``): the bins
    it moves in (indices from the lowest p_direct), of how many, the motion number and success
    the table predicts for that choice, the cap, ``min_z``, and the bins whose choice is within
    two standard errors (``close_bins``)."""
    moves = np.asarray(table.move_value) > 0
    n = np.asarray(table.states, np.float64)
    success = float(np.sum(n * np.where(moves, table.moved, table.direct)) / np.sum(n))
    mn = motion_number(table, moves)  # None where no state succeeded: JSON has no inf
    return {"moving_bins": [int(k) for k in np.flatnonzero(moves)], "bins": int(moves.size),
            "motion_number": round(mn, 4) if np.isfinite(mn) else None, "success": round(success, 4),
            "max_motion_number": float(max_motion_number), "min_z": float(min_z), "close_bins": close_bins(table)}


def moves_at(table: GateTable, p) -> np.ndarray:
    """(N,) bool: p_direct values p (N,) that fall in a bin the table moves (move value > 0),
    each bin found as ``move_value`` finds it (its upper edge excluded)."""
    k = np.searchsorted(np.asarray(table.edges, np.float64), np.asarray(p, np.float64), side="right")
    return np.asarray(table.move_value, np.float64)[k] > 0


def paired_lost(table: GateTable, p, lost_direct, lost_moved) -> dict:
    """Objects knocked off the table per attempt, direct against after a move on the same states
    (N,): over all states and over those the table moves, each with the paired difference
    (moved - direct) and its standard error."""
    p = np.asarray(p, np.float64)
    moves = moves_at(table, p)
    out = {}
    for name, keep in (("all", np.ones(p.shape, bool)), ("moved_bins", moves)):
        d = np.asarray(lost_direct, np.float64)[keep]
        m = np.asarray(lost_moved, np.float64)[keep]
        diff = m - d
        se = float(np.std(diff, ddof=1) / np.sqrt(diff.size)) if diff.size > 1 else float("nan")
        out[name] = {"states": int(keep.sum()), "direct": float(d.mean()) if d.size else float("nan"),
                     "moved": float(m.mean()) if m.size else float("nan"),
                     "difference": float(diff.mean()) if diff.size else float("nan"), "se": se}
    return out


def move_value(table: jax.Array, p_direct: jax.Array) -> jax.Array:
    """table (2, K) (``GateTable.array``), p_direct (B,) -> (B,) the move value of each world's
    bin (positive: a move raises the picks per hour)."""
    k = jnp.searchsorted(table[0, :-1], p_direct, side="right")
    return table[1, k]


def save(run_dir: str, table: GateTable, meta: dict) -> str:
    """Writes RUN/gate.json (the table's fields and ``meta``) -> its path."""
    path = os.path.join(run_dir, GATE_FILE)
    with open(path, "w") as f:
        json.dump({**dataclasses.asdict(table), **meta}, f, indent=1)
    return path


def read(run_dir: str) -> Optional[dict]:
    """RUN/gate.json as written (the table's fields and its meta); None when the run has none."""
    path = os.path.join(run_dir, GATE_FILE)
    if not os.path.isfile(path):
        return None
    with open(path) as f:
        return json.load(f)


def load_table(run_dir: str, networks: Optional[str] = None, gdnet: Optional[str] = None,
               close_gdnet: Optional[str] = None, max_motion_number: float = 0.0,
               split: bool = True, min_z: float = 0.0) -> Optional[GateTable]:
    """RUN/gate.json -> its ``GateTable``, its moves within ``min_z`` standard errors of 0
    dropped (``significant``; 0: none), then capped at ``max_motion_number`` (0: no cap): by
    ``split_capped`` when ``split`` and RUN/``STATES_FILE`` holds the states it was fit on, else
    by whole bins (``capped``); None
    when the run has none, or when ``networks`` (e.g. "stage3 step 80") is not the networks it
    was measured on, ``gdnet`` not their direct grasps' GDNet (its "gdnet"; tables from before
    it was kept: ``networks``) or ``close_gdnet`` not the GDNet of their grasps after a move (its
    "close_gdnet"; tables from before it was kept: "gdnet")."""
    d = read(run_dir)
    if d is None:
        return None
    if networks is not None and d.get("networks") != networks:
        return None
    kept = d.get("gdnet", d.get("networks"))
    if gdnet is not None and kept != gdnet:
        return None
    if close_gdnet is not None and d.get("close_gdnet", kept) != close_gdnet:
        return None
    table = significant(from_dict(d), min_z)
    if split and max_motion_number > 0:
        states = read_states(run_dir)
        if states_match(table, states):
            return split_capped(table, states, max_motion_number)
    return capped(table, max_motion_number)


def estimate_of(run_dir: str) -> str:
    """The success estimate (``config.Vags.gate_estimate``) RUN/gate.json was fit on: its
    "estimate", "grasp" in tables from before it was recorded."""
    d = read(run_dir)
    return "grasp" if d is None else str(d.get("estimate", "grasp"))


def close_score_of(run_dir: str) -> str:
    """The grasp-after-a-move score (``config.Vags.close_score``) RUN/gate.json was measured
    with: its "close_score", "q" in tables from before it was recorded."""
    d = read(run_dir)
    return "q" if d is None else str(d.get("close_score", "q"))


def direct_score_of(run_dir: str) -> str:
    """The direct-grasp planner (``config.Vags.direct_score``) RUN/gate.json was measured with:
    its "direct_score", "q" in tables from before it was recorded."""
    d = read(run_dir)
    return "q" if d is None else str(d.get("direct_score", "q"))


def from_dict(d: dict) -> GateTable:
    """A gate.json's contents -> its ``GateTable`` (the table's fields; the meta is dropped)."""
    fields = {f.name for f in dataclasses.fields(GateTable)}
    return GateTable(**{k: (tuple(v) if isinstance(v, list) else v) for k, v in d.items() if k in fields})


def load(run_dir: str, networks: Optional[str] = None, gdnet: Optional[str] = None,
         close_gdnet: Optional[str] = None, max_motion_number: float = 0.0,
         split: bool = True, min_z: float = 0.0) -> Optional[np.ndarray]:
    """``load_table``'s table as the (2, K) float32 array the decision reads (``GateTable.array``);
    None where it gives None."""
    table = load_table(run_dir, networks, gdnet, close_gdnet, max_motion_number, split, min_z)
    return None if table is None else table.array()


def describe(table: GateTable) -> str:
    """A Markdown table of the bins."""
    lost = bool(table.lost_direct)
    picks = "net picks (picks minus objects knocked off)" if table.count_lost else "picks"
    lines = [f"{picks} per second of the best gate: {table.rate:.4f} ({3600 * table.rate:.0f} per hour at one attempt "
             "per state)", "", "| p_direct bin | states | direct % | after a move % | extra s | move value | moves |"
             + (" lost per 100, direct | lost per 100, after a move |" if lost else ""),
             "|---|---:|---:|---:|---:|---:|---|" + ("---:|---:|" if lost else "")]
    lo = ["-inf"] + [f"{e:.3f}" for e in table.edges]
    hi = [f"{e:.3f}" for e in table.edges] + ["inf"]
    close = close_bins(table)
    for i in range(len(table.states)):
        se = f" ± {table.move_value_se[i]:.3f}" if table.move_value_se else ""
        lines.append(f"| [{lo[i]}, {hi[i]}) | {table.states[i]} | {100 * table.direct[i]:.1f} | "
                     f"{100 * table.moved[i]:.1f} | {table.extra_seconds[i]:+.2f} | {table.move_value[i]:+.3f}{se} | "
                     f"{'yes' if table.move_value[i] > 0 else 'no'}{' *' if i in close else ''} |"
                     + (f" {100 * table.lost_direct[i]:.1f} | {100 * table.lost_moved[i]:.1f} |" if lost else ""))
    if close:
        lines += ["", f"* bins {close}: the move value is within two standard errors of 0 (± one standard error over "
                      "the bin's states shown), so these states cannot tell whether a move pays there; another "
                      "measurement could choose them the other way"]
    lines += ["", "predicted on these states: " + _prediction(table)
              + " (the benchmark's motion number has run 0.01-0.10 above a table's)"]
    if close_moving_bins(table):
        lines.append("with --set vags.gate_min_z=2 (grasp directly in the moving bins marked *): "
                     + _prediction(significant(table, 2.0)))
    return "\n".join(lines)


def _prediction(table: GateTable) -> str:
    """One line: the motion number and success ``table`` predicts on its own states."""
    s = moves_summary(table)
    return (f"{motion_number_text(s['motion_number'])} motions per grasped object, {100 * s['success']:.1f} % success, "
            f"moving in bins {s['moving_bins']}")


def describe_lost(lost: dict) -> str:
    """``paired_lost``'s dict as lines."""
    return "\n".join(f"objects lost per attempt, {name} ({v['states']} states): direct {v['direct']:.3f}, after a "
                     f"move {v['moved']:.3f}, paired difference {v['difference']:+.3f} +- {v['se']:.3f}"
                     for name, v in lost.items())
