"""A trained run on RGB-D frames from outside the simulator: where a real camera's frame enters.

* ``policy``: ``FramePolicy``, the run's VAGS policy on single frames (``Frame``: colour, depth,
  camera-to-world pose, intrinsics), the frame's checks (``check_frame``) and the decision drawn
  on the frame (``draw_decision``).
* ``frames``: the frame files (PNG / .npy images, ``K.json``, ``pose.json``, ``ws.json``) read
  and written, and the simulator's frames of a scene written in the same formats.
* ``commands``: the command line, ``python -m vags_jax.predict`` (``--help``; README "On a real
  robot").
"""
from vags_jax.predict.commands import main, read_frame
from vags_jax.predict.policy import Frame, FramePolicy, check_frame, draw_decision, run_config

__all__ = ["Frame", "FramePolicy", "run_config", "check_frame", "read_frame", "draw_decision", "main"]
