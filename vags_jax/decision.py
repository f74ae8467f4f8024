"""VAGS's decision (paper Fig. 2): grasp directly, or move the camera first.

At the global view GDNet gives grasp Q values ``(B, R, H, W)`` and VANet viewpoint Q values
``(B, H, W)``.  Per world:

* if the largest GDNet Q exceeds ``threshold`` (the paper's best: 1.78), grasp directly at
  GDNet's argmax (rotation, row, col): 1 motion;
* otherwise move the camera to the viewpoint above VANet's argmax cell
  (``camera.viewpoint_pose``: ``camera.viewpoint_height`` above the surface there, looking
  down), take the raw depth image there, and grasp at GG-CNN's best grasp: 2 motions.

Either way it is one grasp attempt.  ``decide`` is the rule on Q maps (pure, batched);
``plan_attempt`` turns a decision into an ``env.Attempt`` for ``VagsEnv.step_attempt`` (every
world renders the close view and runs GG-CNN, so that all worlds take one jitted path; the
direct worlds' close grasps are discarded).  A threshold of ``-inf`` always grasps directly
(GDNet alone: the VANet ablation); ``+inf`` always moves the camera.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp
from flax import struct

from vags_jax.config import Config
from vags_jax.env import EnvState, VagsEnv, select_attempt


@struct.dataclass
class Decision:
    """Per world (B worlds): direct (B,) bool, grasp directly; grasp (B, 3) int32 GDNet's argmax
    [rotation, row, col]; view (B, 2) int32 VANet's argmax [row, col]; q_max (B,) float32 the
    largest GDNet Q."""

    direct: jax.Array
    grasp: jax.Array
    view: jax.Array
    q_max: jax.Array


def _check_maps(q_grasp, q_view) -> None:
    if q_grasp.ndim != 4:
        raise ValueError(f"decide: GDNet Q must be (B, R, H, W), got shape {tuple(q_grasp.shape)}")
    b, _, h, w = q_grasp.shape
    if tuple(q_view.shape) != (b, h, w):
        raise ValueError(f"decide: VANet Q must be (B, H, W) = ({b}, {h}, {w}) like GDNet's, got "
                         f"{tuple(q_view.shape)}")


def decide(q_grasp: jax.Array, q_view: jax.Array, threshold) -> Decision:
    """The decision rule on Q maps: q_grasp (B, R, H, W), q_view (B, H, W), threshold scalar
    (or (B,)); grasp directly where ``max q_grasp > threshold``."""
    _check_maps(q_grasp, q_view)
    b, r, h, w = q_grasp.shape
    flat = q_grasp.reshape(b, -1)
    best = jnp.argmax(flat, axis=1)
    q_max = jnp.take_along_axis(flat, best[:, None], axis=1)[:, 0].astype(jnp.float32)
    grasp = jnp.stack(jnp.unravel_index(best, (r, h, w)), axis=-1).astype(jnp.int32)
    vbest = jnp.argmax(q_view.reshape(b, -1), axis=1)
    view = jnp.stack(jnp.unravel_index(vbest, (h, w)), axis=-1).astype(jnp.int32)
    return Decision(direct=q_max > threshold, grasp=grasp, view=view, q_max=q_max)


def plan_attempt(cfg: Config, env: VagsEnv, state: EnvState, decision: Decision, ggcnn_params, key,
                 ggcnn_model=None, details: bool = False):
    """A decision -> the attempt of every world (``env.Attempt``): GDNet's grasp from the
    global view where ``decision.direct``, else GG-CNN's grasp in the close view taken above
    ``decision.view``.  key: the close image's sensor-noise key.  With ``details`` returns
    ``(attempt, {"image": CameraImage of the close views, "image_grasp": GG-CNN's ImageGrasp})``
    (for pictures of the decision, ``eval.py --record``)."""
    from vags_jax.ggcnn_grasp import predict_grasp
    from vags_jax.networks.ggcnn import GGCNN

    model = GGCNN() if ggcnn_model is None else ggcnn_model
    pos_d, yaw_d = env.grasp_pose(state, decision.grasp[:, 1:], decision.grasp[:, 0])
    pose = env.viewpoint_pose(state, decision.view)
    image = env.camera_image(state.sim, pose, key)
    close, img = predict_grasp(model, ggcnn_params, image.depth, pose, cfg.camera, cfg.ggcnn,
                               cfg.grasp.depth_below_surface)
    attempt = select_attempt(decision.direct, env.direct_attempt(pos_d, yaw_d),
                             env.viewpoint_attempt(close.position, close.yaw, pose))
    return (attempt, {"image": image, "image_grasp": img}) if details else attempt


__all__ = ["Decision", "decide", "plan_attempt"]
