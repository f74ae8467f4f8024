"""VPG's two Q-networks as one module: a push net and a grasp net, each a GDNet (two-stream
trunks, head, 16 rotations), as VPG's push and grasp nets each have their own trunks.

``VPGNet(colour, height)`` -> ``(B, 2R, H, W)``: channels ``0..R-1`` are the push Q maps
(push direction ``r * 2 pi / R``), channels ``R..2R-1`` the grasp Q maps (closing axis
``r * pi / (R / 2)``, as GDNet).  An action ``[channel, row, col]`` over both primitives is the
argmax of the whole tensor, so VPG's "argmax over both primitives" and its target ``max Q(s')``
over both are those of one Q-network (``vags_jax.rl.dqn`` works on it unchanged).
"""
from __future__ import annotations

from typing import Optional

import flax.linen as nn
import jax
import jax.numpy as jnp

from vags_jax.nets.qnet import GDNet


class VPGNet(nn.Module):
    n_rotations: int = 16
    trunk: str = "densenet121"
    small_width: int = 32
    head_channels: int = 64
    dtype: str = "float32"

    def setup(self):
        kw = dict(n_rotations=self.n_rotations, trunk=self.trunk, small_width=self.small_width,
                  head_channels=self.head_channels, dtype=self.dtype)
        self.push_net = GDNet(**kw)
        self.grasp_net = GDNet(**kw)

    def __call__(self, colour: jax.Array, height: jax.Array, train: bool = False,
                 rotations: Optional[jax.Array] = None) -> jax.Array:
        """colour (B, H, W, 3) uint8, height (B, H, W) m; rotations: None for all ``2R``
        channels, or (B, K) channel indices in 0..2R-1 (training: the executed one).
        -> (B, 2R, H, W), or (B, K, H, W) float32.  With ``rotations`` both nets run at each
        index's rotation and the channel's primitive is kept (the other's gradient is zero)."""
        R = self.n_rotations
        if rotations is None:
            return jnp.concatenate([self.push_net(colour, height, train), self.grasp_net(colour, height, train)], 1)
        idx = jnp.asarray(rotations, jnp.int32)
        q_push = self.push_net(colour, height, train, rotations=idx % R)
        q_grasp = self.grasp_net(colour, height, train, rotations=idx % R)
        return jnp.where((idx >= R)[..., None, None], q_grasp, q_push)


def make_vpg_net(net_cfg) -> VPGNet:
    """VPG's nets from a ``config.Net`` (trunk, width, head, dtype, rotations)."""
    if net_cfg.half_turn:
        raise ValueError("VPG pushes in all n_rotations directions of a whole turn, on the grasp net's rotated "
                         "heightmaps: set net.half_turn=false and grasp.half_turn=false for VPG")
    return VPGNet(n_rotations=net_cfg.n_rotations, trunk=net_cfg.trunk, small_width=net_cfg.small_width,
                  head_channels=net_cfg.head_channels, dtype=net_cfg.dtype)


__all__ = ["VPGNet", "make_vpg_net"]
