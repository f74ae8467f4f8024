"""Per-world physics of drawn object sizes: bounds, the batched ``mjx.Model`` each world steps
with, and geom sizes for the renderer (the ``Simulator``'s ``PerWorldModel`` part)."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from mujoco import mjx

from vags_jax.sim.scene import sized_body_physics
from vags_jax.sim.state import SimState


class PerWorldModel:
    """Per-world sizes of a ``Simulator`` (uses its ``cfg``, ``scene``, ``mx``, object tables)."""

    def object_bounds(self, obj_size):
        """Per-world bounds of every pool body: obj_size (B, P, 3) -> (aabb (B, P, 6) geom-frame
        centre + half size, rbound (B, P)).  Fixed shapes keep their compiled values."""
        aabb = jnp.broadcast_to(jnp.asarray(self._obj_aabb), obj_size.shape[:-1] + (6,))
        rbound = jnp.broadcast_to(jnp.asarray(self._obj_rbound), obj_size.shape[:-1])
        if not self._sized:
            return aabb, rbound
        phys = sized_body_physics(jnp.asarray(self.scene.object_kind), obj_size, self.cfg.scene.object_density)
        fixed = jnp.asarray(self._fixed)
        aabb = jnp.where(fixed[..., None], aabb, jnp.concatenate([jnp.zeros_like(obj_size), phys["aabb_half"]], -1))
        return aabb, jnp.where(fixed, rbound, phys["rbound"])

    def world_model(self, obj_size):
        """The model each world steps with -> (mjx.Model, vmap in_axes).

        With sized families, the object geoms' ``geom_size``, their bounds and their bodies'
        mass, inertia and inverse weights are per-world model fields (leading dim B; MJX jax
        and MuJoCo Warp both batch these); otherwise the shared model (in_axes None).
        """
        if not self._sized:
            return self.mx, None
        mx, sc = self.mx, self.scene
        B = obj_size.shape[0]
        fixed = jnp.asarray(self._fixed)
        phys = sized_body_physics(jnp.asarray(sc.object_kind), obj_size, self.cfg.scene.object_density)
        gid, bid = sc.object_geom_ids, sc.object_body_ids

        def per_world(field, rows, new):
            base = jnp.broadcast_to(field, (B,) + field.shape)
            keep = base[:, rows]
            f = fixed.reshape((1, -1) + (1,) * (keep.ndim - 2))
            return base.at[:, rows].set(jnp.where(f, keep, new.reshape(keep.shape).astype(field.dtype)))

        aabb = jnp.concatenate([jnp.zeros_like(obj_size), phys["aabb_half"]], -1)  # (B, P, 6)
        dof = sc.object_dof_adr[:, None] + np.arange(6)  # (P, 6)
        invw = phys["invweight"]
        dof_inv = jnp.repeat(invw, 3, axis=-1)  # (B, P, 6): 3 x translational, 3 x rotational
        fields = dict(
            geom_size=per_world(mx.geom_size, gid, obj_size),
            geom_rbound=per_world(mx.geom_rbound, gid, phys["rbound"]),
            geom_aabb=per_world(mx.geom_aabb, gid, aabb),
            body_mass=per_world(mx.body_mass, bid, phys["mass"]),
            body_inertia=per_world(mx.body_inertia, bid, phys["inertia"]),
            body_invweight0=per_world(mx.body_invweight0, bid, invw),
        )
        dof_b = jnp.broadcast_to(mx.dof_invweight0, (B,) + mx.dof_invweight0.shape)
        keep = dof_b[:, dof]  # (B, P, 6)
        fields["dof_invweight0"] = dof_b.at[:, dof].set(jnp.where(fixed[None, :, None], keep, dof_inv))
        axes = jax.tree.map(lambda _: None, mx).replace(**{k: 0 for k in fields})
        return mx.replace(**fields), axes

    def _stepper(self, obj_size):
        """-> step(d) advancing every world one physics step with its own model."""
        m, axes = self.world_model(obj_size)
        batched = jax.vmap(mjx.step, in_axes=(axes, 0))
        return lambda d: batched(m, d)

    def geom_size(self, state: SimState):
        """(B, ngeom, 3) per-world geom sizes for the renderer, or None when no size is drawn."""
        if not self._sized:
            return None
        base = jnp.broadcast_to(jnp.asarray(self.scene.mj_model.geom_size, jnp.float32),
                                (state.n_worlds,) + self.scene.mj_model.geom_size.shape)
        return base.at[:, self.scene.object_geom_ids].set(state.obj_size)
