"""Drawing new scenes: object draws, scatter spawn heights, pile drops and the reset
(the ``Simulator``'s ``ScenePiles`` part)."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from mujoco import mjx

from vags_jax.sim.state import Drops, SimState

SPAWN_GAP = 0.005  # m between bounding spheres of stacked spawn poses

# "pile" placement: each body is dropped from this far above what lies under it, tilted up to
# PILE_TILT; the drops are spread over the first PILE_DROP_SHARE of the reset's settle time.
PILE_GAP = 0.02  # m
PILE_DROP_SHARE = 0.5
PILE_TILT = 0.35  # rad (20 deg)


def _quat_mul(a, b):
    """Hamilton product of (..., 4) wxyz quaternions."""
    aw, ax, ay, az = jnp.moveaxis(a, -1, 0)
    bw, bx, by, bz = jnp.moveaxis(b, -1, 0)
    return jnp.stack([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                      aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw], -1)


def _quat_to_mat(q):
    """(..., 4) unit wxyz quaternions -> (..., 3, 3) rotation matrices."""
    w, x, y, z = jnp.moveaxis(q, -1, 0)
    return jnp.stack([
        jnp.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        jnp.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        jnp.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], -2)


def _is_traced(x) -> bool:
    return isinstance(x, jax.core.Tracer)



class ScenePiles:
    """Scene draws and resets of a ``Simulator`` (uses its ``cfg``, ``scene`` and the other parts)."""

    def _drop_due(self, d: mjx.Data, active, t, drops: Drops, bounds):
        """Drop the bodies whose release step is ``t``: each is placed at rest with its bottom
        ``PILE_GAP`` above the highest top of the active bodies it may land on (bounding
        spheres overlapping in xy), or above the table.  bounds: ``object_bounds`` of the
        worlds' sizes.  -> (data, active (B, P))."""
        due = drops.release == t  # (B, P)
        ids = self.scene.object_geom_ids
        pos, rot = d.geom_xpos[:, ids], d.geom_xmat[:, ids]
        rz = rot[:, :, 2, :]
        aabb, rbound = bounds
        top = pos[..., 2] + (rz * aabb[..., :3]).sum(-1) + (jnp.abs(rz) * aabb[..., 3:]).sum(-1)  # (B, P)
        dist = jnp.linalg.norm(drops.xy[:, :, None] - pos[:, None, :, :2], axis=-1)  # (B, P new, P old)
        under = active[:, None, :] & (dist < drops.radius[:, :, None] + rbound[:, None, :])
        floor = jnp.where(under, top[:, None, :], self.cfg.workspace.table_z).max(axis=-1)  # (B, P)
        z = floor + drops.half_z + PILE_GAP
        pose = jnp.concatenate([drops.xy, z[..., None], drops.quat], axis=-1)  # (B, P, 7)
        q = d.qpos[:, self._obj_qidx]
        d = d.replace(qpos=d.qpos.at[:, self._obj_qidx].set(jnp.where(due[..., None], pose, q)),
                      qvel=d.qvel.at[:, self._obj_vidx].set(jnp.where(due[..., None], 0.0, d.qvel[:, self._obj_vidx])))
        return d, active | due

    def _sample_world(self, key, n):
        """One world's draw: n () int -> obj_qpos (P, 7), active (P,), rgb (P, 3) uint8,
        size (P, 3) geom_size.

        Sizes: each sized body's geom_size uniform in its range (``SceneModel.object_size_lo``
        .. ``hi``: box sides independently, capsule radius and length, sphere radius).
        Colours: a palette colour per body (distinct within the world for up to 10), each
        channel scaled by a factor in 1 +- ``colour_jitter``.  Placement (``Scene.placement``):
        "scatter": x, y uniform over the workspace shrunk by ``drop_margin``; "pile": uniform
        in a disc of radius ``pile_radius`` around a centre drawn like a scatter position.
        Either way bodies are spawned in draw order, each above every earlier one whose
        bounding sphere overlaps it in xy (no interpenetration), so overlapping ones are
        dropped one after another onto each other.
        """
        cfg, sc = self.cfg, self.scene
        P, N = self.P, self.N
        k_perm, k_xy, k_rot, k_col, k_size, k_jit, k_ctr = jax.random.split(key, 7)
        perm = jax.random.permutation(k_perm, P)  # perm[j] = j-th drawn body
        rank = jnp.argsort(perm)  # rank[i] = draw position of body i
        active = rank < n
        lo_s, hi_s = jnp.asarray(sc.object_size_lo), jnp.asarray(sc.object_size_hi)
        size = lo_s + jax.random.uniform(k_size, (P, 3)) * (hi_s - lo_s)
        xmin, xmax, ymin, ymax = cfg.workspace.bounds
        mg = cfg.scene.drop_margin
        lo = jnp.array([xmin + mg, ymin + mg])
        hi = jnp.array([xmax - mg, ymax - mg])
        if cfg.scene.placement == "pile":
            centre = jax.random.uniform(k_ctr, (2,), minval=lo, maxval=hi)
            k_r, k_t = jax.random.split(k_xy)
            r = cfg.scene.pile_radius * jnp.sqrt(jax.random.uniform(k_r, (P,)))
            t = 2 * jnp.pi * jax.random.uniform(k_t, (P,))
            xy = centre + jnp.stack([r * jnp.cos(t), r * jnp.sin(t)], axis=1)
        else:
            xy = jax.random.uniform(k_xy, (P, 2), minval=lo, maxval=hi)
        slot = perm[:N]
        park = jnp.asarray(sc.park_qpos)
        if cfg.scene.placement == "pile":
            quat, half_z = self._pile_orientations(k_rot, size)
            _, radius = self.object_bounds(size[None])
            release = jnp.where(active, rank * self.pile_release_interval, -1).astype(jnp.int32)
            drops = Drops(release=release, xy=xy, quat=quat, half_z=half_z, radius=radius[0])
            obj_qpos = park  # every body waits parked for its drop
        else:
            quat = jax.random.normal(k_rot, (P, 4))
            quat = quat / jnp.linalg.norm(quat, axis=1, keepdims=True)
            z = self._scatter_spawn(size, xy, slot)
            drops = Drops(release=jnp.full((P,), -1, jnp.int32), xy=xy, quat=quat,
                          half_z=jnp.zeros(P), radius=jnp.zeros(P))
            obj_qpos = jnp.where(active[:, None], jnp.concatenate([xy, z[:, None], quat], axis=1), park)
        colours = jax.random.permutation(k_col, sc.palette.shape[0])
        base_rgb = jnp.asarray(sc.palette, jnp.float32)[colours[rank % sc.palette.shape[0]]]
        j = cfg.scene.colour_jitter
        scale = jax.random.uniform(k_jit, (P, 3), minval=1.0 - j, maxval=1.0 + j)
        rgb = jnp.clip(jnp.round(base_rgb * scale), 0, 255).astype(jnp.uint8)
        return obj_qpos, active, rgb, size.astype(jnp.float32), drops

    def _scatter_spawn(self, size, xy, slot):
        """Spawn heights (P,) for "scatter": centres at ``drop_height`` (or higher), each body
        above every earlier-drawn one whose bounding sphere overlaps it in xy."""
        cfg, sc, N = self.cfg, self.scene, self.N
        _, radius = self.object_bounds(size[None])
        radius = jnp.where(jnp.asarray(self._fixed), jnp.asarray(sc.object_radius), radius[0])
        sxy, sr = xy[slot], radius[slot]
        base = cfg.workspace.table_z + jnp.maximum(cfg.scene.drop_height, sr + SPAWN_GAP)

        def place(j, z):
            dist = jnp.linalg.norm(sxy - sxy[j], axis=1)
            overlap = (jnp.arange(N) < j) & (dist < sr + sr[j] + SPAWN_GAP)
            above = jnp.where(overlap, z + sr + sr[j] + SPAWN_GAP, -jnp.inf).max()
            return z.at[j].set(jnp.maximum(base[j], above))

        sz = jax.lax.fori_loop(0, N, place, jnp.zeros(N))
        return jnp.zeros(self.P).at[slot].set(sz)

    def _pile_orientations(self, key, size):
        """Drop orientations (P, 4) wxyz for "pile" and the half heights (P,) of the bodies'
        world bounding boxes in them: each body lies on a random face (x, y or z axis up),
        tilted up to ``PILE_TILT`` rad about a random horizontal axis, at a random yaw."""
        P = self.P
        k_face, k_tilt_axis, k_tilt, k_yaw = jax.random.split(key, 4)
        s2 = np.sqrt(0.5)
        faces = jnp.array([[1.0, 0, 0, 0], [s2, 0, -s2, 0], [s2, s2, 0, 0]])  # z up, x up, y up
        q_face = faces[jax.random.randint(k_face, (P,), 0, 3)]
        phi = 2 * jnp.pi * jax.random.uniform(k_tilt_axis, (P,))
        tilt = PILE_TILT * jax.random.uniform(k_tilt, (P,))
        q_tilt = jnp.stack([jnp.cos(tilt / 2), jnp.cos(phi) * jnp.sin(tilt / 2),
                            jnp.sin(phi) * jnp.sin(tilt / 2), jnp.zeros(P)], -1)
        yaw = 2 * jnp.pi * jax.random.uniform(k_yaw, (P,))
        q_yaw = jnp.stack([jnp.cos(yaw / 2), jnp.zeros(P), jnp.zeros(P), jnp.sin(yaw / 2)], -1)
        quat = _quat_mul(q_yaw, _quat_mul(q_tilt, q_face))
        aabb, _ = self.object_bounds(size[None])
        rz = _quat_to_mat(quat)[:, 2, :]  # (P, 3) world z of each body axis
        half_z = (jnp.abs(rz) * aabb[0, :, 3:]).sum(-1) + (rz * aabb[0, :, :3]).sum(-1)
        return quat, half_z

    def _start_rounds(self, state: SimState, mask, keys, n_objects):
        """Worlds with mask (B,) get a new scene drawn with keys (B, 2) and n_objects (B,):
        new sizes and colours, flags cleared, objects placed at their spawn poses at rest
        ("scatter") or parked until their drop ("pile"; returned ``Drops``).  No physics: the
        caller lets the scene settle, passing the ``Drops`` to its loop.  The other worlds are
        unchanged.  -> (SimState, Drops, or None for "scatter", where nothing is dropped later)."""
        d = state.data
        obj_qpos, active, rgb, size, drops = jax.vmap(self._sample_world)(keys, n_objects)
        m3 = mask[:, None, None]
        drops = drops.replace(release=jnp.where(mask[:, None], drops.release, -1))
        placed = active & (drops.release < 0)  # scatter: every drawn body; pile: none yet
        d = d.replace(
            qpos=d.qpos.at[:, self._obj_qidx].set(jnp.where(m3, obj_qpos, d.qpos[:, self._obj_qidx])),
            qvel=d.qvel.at[:, self._obj_vidx].set(jnp.where(m3, 0.0, d.qvel[:, self._obj_vidx])),
            qacc_warmstart=jnp.where(mask[:, None], 0.0, d.qacc_warmstart),
        )
        d = self._wake(d, mask)
        ids = self.scene.object_geom_ids
        state = state.replace(
            data=d,
            active=jnp.where(mask[:, None], placed, state.active),
            geom_rgb=state.geom_rgb.at[:, ids].set(jnp.where(m3, rgb, state.geom_rgb[:, ids])),
            n_objects=jnp.where(mask, n_objects.astype(jnp.int32), state.n_objects),
            error=state.error & ~mask, overflow=state.overflow & ~mask,
            obj_size=jnp.where(m3, size, state.obj_size),
        )
        return state, (drops if self.cfg.scene.placement == "pile" else None)

    def _reset_impl(self, keys, n_objects) -> SimState:
        B = keys.shape[0]
        state, drops = self._start_rounds(self._empty_impl(B), jnp.ones((B,), bool), keys, n_objects)
        park_ctrl = self._park_ctrl(B)
        d, active, ovf = self._run(state.data, state.active, state.overflow, lambda _: park_ctrl,
                                   jnp.zeros((self.n_settle_reset,)), state.obj_size, drops)
        return self._housekeep(state.replace(data=d, active=active, overflow=ovf))

    def _redrop_impl(self, state: SimState, keys, n_objects) -> SimState:
        _, drawn, _, _, drops = jax.vmap(self._sample_world)(keys, n_objects)  # the reset's draws again
        lost = drawn & ~state.active & ~state.error[:, None]  # (B, P) drawn, now off the table
        order = jnp.cumsum(lost, axis=1) - 1  # the lost bodies drop one after another
        drops = drops.replace(release=jnp.where(lost, order * self.pile_release_interval, -1).astype(jnp.int32))
        d = self._wake(state.data, lost.any(axis=1))
        park_ctrl = self._park_ctrl(keys.shape[0])
        d, active, ovf = self._run(d, state.active, state.overflow, lambda _: park_ctrl,
                                   jnp.zeros((self.n_settle_reset,)), state.obj_size, drops)
        return self._housekeep(state.replace(data=d, active=active, overflow=ovf))

    def redrop_batched(self, state: SimState, keys, n_objects) -> SimState:
        """Drop the pile objects that left the table again, onto their pile: state from
        ``reset_batched(keys, n_objects)`` with the same keys (B, 2) and n_objects (B,) int32.

        Each world's drawn objects that are no longer active (spilled out of the workspace) are
        released again, one after another, from their own drop position and orientation, above
        whatever lies there (as in the reset's drop), and every world settles for the reset's
        settle time.  The draws (which objects, sizes, colours) do not change.  Worlds whose
        physics failed are left as they are; worlds with nothing lost just settle on.  "pile"
        placement only.  -> SimState."""
        return self._redrop_jit(state, keys, n_objects)

    def reset(self, key, n_objects) -> SimState:
        """New scenes.  key: (2,) or (B, 2) uint32 (or typed key () / (B,)); n_objects: (B,) int.

        Concrete n_objects outside 1..N raise ValueError; traced ones (inside an outer jit)
        are not checked.  Returns a SimState with B worlds.
        """
        if jnp.issubdtype(jnp.asarray(key).dtype, jax.dtypes.prng_key):
            key = jax.random.key_data(key)
        n_arr = jnp.asarray(n_objects)
        if not _is_traced(n_objects):
            n_np = np.asarray(n_objects)
            if not np.issubdtype(n_np.dtype, np.integer) or n_np.ndim > 1 or n_np.size == 0 \
                    or n_np.min() < 1 or n_np.max() > self.N:
                raise ValueError(
                    f"n_objects must be integers in 1..{self.N} (Config.scene.max_objects = "
                    f"{self.N}), one per world as a (B,) array; got {n_np.tolist()!r}"
                )
        n_arr = jnp.atleast_1d(n_arr).astype(jnp.int32)
        key = jnp.asarray(key)
        if key.ndim == 1:
            keys = jax.random.split(key, n_arr.shape[0])
        elif key.ndim == 2:
            keys = key
            if n_arr.shape[0] == 1 and keys.shape[0] > 1:
                n_arr = jnp.broadcast_to(n_arr, (keys.shape[0],))
            if keys.shape[0] != n_arr.shape[0]:
                raise ValueError(
                    f"reset: key has {keys.shape[0]} worlds but n_objects has {n_arr.shape[0]}"
                )
        else:
            raise ValueError(f"reset: key must have shape (2,) or (B, 2), got {key.shape}")
        return self._reset_jit(keys, n_arr)
