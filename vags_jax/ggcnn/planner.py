"""GG-CNN as a grasp planner: a raw camera depth image -> a world grasp for the simulator.

Used by the ``ggcnn`` / ``ggcnn-close`` policies of ``eval.py`` (and by VAGS's viewpoint
branch), by the held-out check of ``train.py --stage ggcnn``, and by the dataset maker to turn
candidate grasps drawn in the network's image into world grasps, so that a label and a
prediction at the same pixel mean the same grasp.

Pipeline (conventions of ``vags_jax.ggcnn.process``)::

    x, filled, K_in, valid = network_input(depth, cam_cfg, gcfg)  # (B, S, S), S = input_size
    maps = GGCNN().apply(params, x)                          # GraspMaps (B, S, S)
    img = best_grasp(maps, gcfg, valid)                      # quality peak, never in a hole
    grasp = image_to_world(img.pixel, img.angle, img.width_px, filled, K_in, pose, depth_below)

The grasp centre is ``depth_below`` (``Grasp.depth_below_surface``) under the surface point
seen at the pixel, in world z: the rule of the heightmap grasps.  The gripper always opens
fully (``Grasp.finger_stroke``); the predicted width is reported, not executed.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp

from vags_jax.perception import camera
from vags_jax.config import Camera, GGCNNConfig
from vags_jax.ggcnn.process import (ImageGrasp, WorldGrasp, best_grasp, crop_resize, grasp_to_world,
                                    preprocess_depth, valid_depth)
from vags_jax.nets.ggcnn import GGCNN


def network_input(depth: jax.Array, cam_cfg: Camera, gcfg: GGCNNConfig):
    """Camera depth (B, h, w) metres (0 = missing) -> ``(x, filled, K_in, valid)``.

    x: (B, S, S) float32 network input (inpainted, mean-subtracted, clipped);
    filled: (B, S, S) inpainted depth in metres at the network resolution;
    K_in: (B, 3, 3) intrinsics of that resolution (``crop_resize``);
    valid: (B, S, S) bool, the pixels that had depth before inpainting.
    """
    d, k_in = crop_resize(depth, camera.intrinsics(cam_cfg), gcfg)
    x, filled, _ = preprocess_depth(d, gcfg)
    return x, filled, k_in, valid_depth(d)


def image_to_world(pixel, angle, width_px, filled, k_in, pose, depth_below: float) -> WorldGrasp:
    """Grasps in the network image -> world grasps, batched over (B, ...) leading axes.

    pixel (B, ..., 2) [u, v]; angle, width_px (B, ...); filled (B, S, S) metres; k_in (B, 3, 3);
    pose (B, 4, 4).  The surface point at the pixel, lowered by ``depth_below`` in world z.
    """
    pixel = jnp.asarray(pixel)
    b, s = filled.shape[0], filled.shape[-1]
    lead = pixel.shape[1:-1]
    flat = jnp.clip(jnp.round(pixel).astype(jnp.int32), 0, s - 1).reshape(b, -1, 2)
    z = jnp.take_along_axis(filled.reshape(b, -1), flat[..., 1] * s + flat[..., 0], axis=1).reshape((b,) + lead)
    extra = (1,) * len(lead)
    g = grasp_to_world(pixel, angle, width_px, z, k_in.reshape((b,) + extra + (3, 3)),
                       pose.reshape((b,) + extra + (4, 4)))
    return g.replace(position=g.position.at[..., 2].add(-depth_below))


def predict_grasp(model: GGCNN, params, depth: jax.Array, pose: jax.Array, cam_cfg: Camera,
                  gcfg: GGCNNConfig, depth_below: float):
    """GG-CNN's best grasp in each camera image -> ``(WorldGrasp (B,), ImageGrasp (B,))``.

    depth: (B, h, w) raw camera depth (``VagsEnv.camera_image``); pose: (B, 4, 4) where it was
    taken; params: ``{"params": ...}`` of GG-CNN.  The grasp's pixel had depth in the raw
    image whenever any pixel did (``best_grasp``'s ``valid``).
    """
    x, filled, k_in, valid = network_input(depth, cam_cfg, gcfg)
    img = best_grasp(model.apply(params, x), gcfg, valid)
    return image_to_world(img.pixel, img.angle, img.width_px, filled, k_in, pose, depth_below), img


__all__ = ["network_input", "image_to_world", "predict_grasp", "ImageGrasp", "WorldGrasp"]
