"""``driver.run_chunks`` on a stand-in stage (tiny jitted programs, no physics): when it
checkpoints (every N chunks, or by time), that it names a chunk after the first that compiles,
and the first chunk whose physics overflowed its buffers."""
from types import SimpleNamespace

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from vags_jax.stages import checkpoint, driver

KEYS = ("attempts", "attempts_total", "success_rate", "epsilon", "explored") + driver.FINITE_METRICS


@struct.dataclass
class State:
    x: jax.Array
    attempts: jax.Array


class Stage:
    """``run(state, n)``: n iterations of +1; ``fresh=True`` builds a new program at every call."""

    def __init__(self, fresh: bool = False, overflow_from: int = 0):
        self.fresh, self.calls, self.overflow_from = fresh, 0, overflow_from
        self.step = jax.jit(lambda x: x + 1.0)

    def run(self, state, n):
        self.calls += 1
        step = jax.jit(lambda x, c=float(self.calls): x + c) if self.fresh else self.step
        done = state.attempts + n
        m = {k: np.zeros(n, np.float32) for k in KEYS}
        m["attempts"][:] = 1
        m["attempts_total"][:] = np.arange(int(state.attempts) + 1, int(done) + 1)
        if self.overflow_from:  # worlds whose buffers overflowed, from that iteration on (1-based)
            m["buffer_overflow"] = (np.arange(int(state.attempts) + 1, int(done) + 1) >= self.overflow_from) * 2.0
        return State(x=step(state.x), attempts=jnp.asarray(done, jnp.int32)), m


def _run(tmp_path, stage, **flags):
    tmp_path.mkdir()
    out = str(tmp_path)
    args = SimpleNamespace(chunk=2, quiet=True, out=out, max_minutes=None,
                           **{"checkpoint_every": None, "checkpoint_minutes": None, **flags})
    state = State(x=jnp.zeros(3), attempts=jnp.zeros((), jnp.int32))
    recompiles = []
    _, it, status, _, _ = driver.run_chunks("stage1", stage, state, 0, 8, out, args, None, recompiles=recompiles)
    assert (it, status) == (8, "done")
    return checkpoint.checkpoint_steps(out), recompiles


def test_checkpoints_every_n_chunks_or_by_time(tmp_path):
    assert _run(tmp_path / "every2", Stage(), checkpoint_every=2)[0] == [4, 8]
    # Every chunk boundary is due; the run directory keeps the last three checkpoints.
    assert _run(tmp_path / "always", Stage(), checkpoint_minutes=1e-9)[0] == [4, 6, 8]
    # The default spacing (5 minutes) is far longer than this loop: the end alone is saved.
    assert _run(tmp_path / "default", Stage())[0] == [8]


def test_a_chunk_that_compiles_after_the_first_is_named(tmp_path, capsys):
    _, recompiles = _run(tmp_path / "stable", Stage())
    assert recompiles == []
    _, recompiles = _run(tmp_path / "fresh", Stage(fresh=True))
    assert recompiles == [4, 6, 8]  # the chunks ending there built and compiled a new program
    assert "warning: stage1's chunk up to iteration 4 compiled" in capsys.readouterr().err


def test_the_first_chunk_whose_buffers_overflowed_is_named_once(tmp_path, capsys):
    _run(tmp_path / "clean", Stage(overflow_from=0))
    assert "overflowed" not in capsys.readouterr().err
    # Iteration 4 on overflows in 2 worlds: the chunk of iterations 3-4 shows 2 world-iterations,
    # and is the only one named although the chunks after it overflow too.
    _run(tmp_path / "overflow", Stage(overflow_from=4))
    err = capsys.readouterr().err
    assert err.count("overflowed") == 1
    assert "warning: stage1: contact/constraint buffers overflowed in 2 world-iteration(s) of iterations 3-4" in err
    assert "sim.contacts_per_world" in err


def test_on_first_chunk_runs_once_after_the_first_chunk(tmp_path):
    tmp_path.mkdir(exist_ok=True)
    calls = []
    stage = Stage()
    args = SimpleNamespace(chunk=2, quiet=True, out=str(tmp_path), max_minutes=None, checkpoint_every=None,
                           checkpoint_minutes=None)
    state = State(x=jnp.zeros(3), attempts=jnp.zeros((), jnp.int32))
    driver.run_chunks("stage1", stage, state, 0, 8, str(tmp_path), args, None,
                      on_first_chunk=lambda: calls.append(stage.calls))
    assert calls == [1]  # once, when the first of the four chunks had run


def test_the_last_checkpoint_can_be_left_writing_for_the_caller(tmp_path):
    """With ``deferred``, the stage's last checkpoint comes back as a save still being written
    (the pipeline starts the next stage meanwhile); the earlier ones are waited for.  Once
    finished, the step is on disk; a stage stopped early waits for its save."""
    out = tmp_path / "deferred"
    out.mkdir()
    args = SimpleNamespace(chunk=2, quiet=True, out=str(out), max_minutes=None, checkpoint_every=2,
                           checkpoint_minutes=None)
    state = State(x=jnp.zeros(3), attempts=jnp.zeros((), jnp.int32))
    deferred = []
    final, it, status, _, _ = driver.run_chunks("stage1", Stage(), state, 0, 8, str(out), args, None,
                                                deferred=deferred)
    assert (it, status) == (8, "done") and [p.step for p in deferred] == [8]
    assert 4 in checkpoint.checkpoint_steps(str(out))  # every save before the last was waited for
    assert deferred[0].finish() >= 0.0 and deferred[0].finish() == 0.0  # once
    assert checkpoint.checkpoint_steps(str(out)) == [4, 8]
    restored, _ = checkpoint.restore(str(out), state, 8)
    assert isinstance(restored.x, jax.Array) and isinstance(restored.attempts, jax.Array)
    np.testing.assert_array_equal(np.asarray(restored.x), np.asarray(final.x))
    assert int(restored.attempts) == 8
    # Out of time after the first chunk: that checkpoint is the stage's end for now, and is waited for.
    early = tmp_path / "early"
    early.mkdir()
    deferred = []
    _, it, status, _, _ = driver.run_chunks("stage1", Stage(), state, 0, 8, str(early),
                                            SimpleNamespace(**{**vars(args), "out": str(early)}), 0.0,
                                            deferred=deferred)
    assert (it, status, deferred) == (2, "out_of_time", [])
    assert checkpoint.checkpoint_steps(str(early)) == [2]
