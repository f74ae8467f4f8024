"""GG-CNN's pieces: data labelled in physics, label maps, image processing, the planner, training.

* ``data``: views of random scenes and candidate grasps tried in batched physics; the disk cache.
* ``labels``: candidates -> quality / cos 2theta / sin 2theta / width maps (centre-third rule).
* ``process``: depth -> network input (inpaint, crop, resize); maps -> best grasp.
* ``planner``: a raw depth image -> a world grasp for the simulator.
* ``train``: loss, augmentation, Adam step.
The network itself is ``vags_jax.nets.ggcnn``; its training stage ``vags_jax.stages.ggcnn``.
"""
