"""Reinforcement learning that knows nothing of grasping: pure functions over pytrees.

* ``dqn``: train state, TD target, Huber loss on the executed action, update step.
* ``replay``: prioritized replay on the accelerator (flashbax-style init / add / sample).
* ``exploration``: DAES, epsilon-greedy whose random actions fall on occupied cells.
"""
