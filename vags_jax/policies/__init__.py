"""Policies: how an attempt is planned, shared by training and the benchmark.

* ``decision``: VAGS's decision (the gate, GDNet's direct grasp, VANet's viewpoint and the
  close-view planner), used by stages 2-3 and by the ``vags`` benchmark policy.
* ``base``: the ``Policy`` interface and ``make_policy`` by name.
* ``scripted``: ``random``, ``highest``, ``heuristic`` (minimum-width grasp).
* ``learned``: ``gdnet``, ``vags``, ``ggcnn`` and ``ggcnn-close``.
"""
