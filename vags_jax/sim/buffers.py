"""Contact and constraint buffers (MuJoCo Warp's fixed sizes, MJX jax's kept contacts) and the
per-step overflow flag: the ``Simulator``'s ``BufferSizes`` part."""
from __future__ import annotations

import jax
import jax.numpy as jnp
from mujoco import mjx

from vags_jax.sim.scene import contacts_per_world, rows_per_contact
from vags_jax.sim.state import WARP_BUFFER_OVERFLOW_BITS


class BufferSizes:
    """Buffers of a ``Simulator`` (uses its ``cfg``, ``scene``, ``impl``, ``mx``)."""

    @property
    def contacts_per_world(self) -> int:
        return contacts_per_world(self.cfg)

    def buffer_sizes(self, n_worlds: int) -> tuple[int, int]:
        """(naconmax over all worlds, njmax per world) used for impl "warp"."""
        nacon = self.cfg.sim.naconmax or n_worlds * self.contacts_per_world
        njmax = self.cfg.sim.njmax or rows_per_contact(self.cfg) * self.contacts_per_world + 16
        return int(nacon), int(njmax)

    def _template(self, n_worlds: int) -> mjx.Data:
        key = n_worlds if self.impl == "warp" else 0
        if key not in self._template_cache:
            # Built eagerly (concrete arrays) even when first asked for inside a jit trace.
            with jax.ensure_compile_time_eval():
                self._template_cache[key] = self._make_template(n_worlds)
        return self._template_cache[key]

    def _make_template(self, n_worlds: int) -> mjx.Data:
        """One unbatched Data; for warp its buffers are sized for ``n_worlds`` worlds."""
        if self.impl == "warp":
            nacon, njmax = self.buffer_sizes(n_worlds)
            return mjx.make_data(self.scene.mj_model, impl="warp", naconmax=nacon, njmax=njmax)
        return mjx.make_data(self.mx, impl="jax")

    def _overflow_now(self, d: mjx.Data, B: int) -> jax.Array:
        """(B,) bool: a contact / constraint buffer is full after this step.

        Buffers and failures (never silently accepted):
        * impl "warp": contacts and constraint rows live in fixed buffers (``naconmax`` contacts over
          all worlds, ``njmax`` rows per world).  If ``cfg.sim.naconmax`` / ``njmax`` are None they
          are sized from the scene: only active objects and the gripper can touch anything (parked
          bodies are pinned far apart), so per world ``contacts_per_world`` = ``20 * N + 56``
          contacts unless set (each object on the table 4, object-object ~16 per object, 2 pads x
          up to 3 objects x 8 + pads on table) and ``3 * that + 16`` rows (6 * that + 16 when capsules or
          spheres, whose contacts have rolling friction (condim 6), are in the pool) (elliptic condim-3
          contacts use 3 rows, plus the finger equality and limits).
          After every step the simulator compares the contact count / rows with the buffers; a full
          buffer sets ``state.overflow`` for the world (for contacts: every world, the count is
          global).
        * impl "jax": MJX jax evaluates every candidate geom pair every step with a fixed number of
          contact slots per pair (for the default 20-body pool about 1000 contacts and 3000
          constraint rows per world, almost all between far-apart bodies).  The scene sets MJX's
          ``max_contact_points`` to ``contacts_per_world`` (same formula / config field as warp), so
          only the deepest contacts reach the solver.  Overflow = every kept contact penetrates
          (more may have been dropped): ``state.overflow``.  Tiny scenes with fewer candidate
          slots than the budget cannot overflow.  Numerical failures (NaNs, an object through the
          table) set ``state.error`` (both impls).
        Solver settings (ls_iterations 20, the 2 ms step of MJX jax, impratio 1 in ``tiny``): the
        measurements are in bench/RESULTS.md, "Environment throughput".
        Only NaNs and tunnelling are flagged (``error``); objects launched out of the workspace are
        deactivated (counted as lost by the evaluation), so keep ls_iterations at 20.
        ``check_overflow(state)`` (host side, between jitted calls) raises ``RuntimeError`` naming
        the worlds and what to change (or warns with ``warn=True``).  Inside a jitted training loop
        the flags are carried in the state: reset worlds whose ``error`` is set.
        """
        if self.impl != "warp":
            # MJX jax keeps the deepest max_contact_points contacts: full when all kept
            # contacts are penetrating (more may have been dropped).
            dist = d._impl.contact.dist  # noqa: SLF001  (B, ncon)
            if dist.shape[-1] < self.contacts_per_world:
                return jnp.zeros((B,), bool)  # every candidate pair has its slots
            return (dist.reshape(B, -1) < 0).sum(axis=1) >= dist.shape[-1]
        impl = d._impl  # noqa: SLF001
        nacon = jnp.max(jnp.asarray(impl.nacon))
        nefc = jnp.asarray(impl.nefc).reshape(B, -1).max(axis=1)
        full = (nacon >= impl.naconmax) | (nefc >= impl.njmax)
        # MuJoCo Warp's own per-world bitmask: constraint rows, broadphase, narrowphase /
        # contact, CCD and EPA buffers that were too small on this step.
        flags = jnp.asarray(impl.overflow).reshape(B, -1).max(axis=1)
        return full | ((flags & WARP_BUFFER_OVERFLOW_BITS) != 0)
