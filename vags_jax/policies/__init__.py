"""Policies: how an attempt is planned, shared by training and the benchmark.

* ``decision``: VAGS's decision (the gate, GDNet's direct grasp, VANet's viewpoint and the
  close-view planner), used by stages 2-3 and by the ``vags`` benchmark policy.
* ``catalog``: the ``Policy`` interface and every benchmark policy by name (``make_policy``):
  scripted ``random``, ``highest``, ``heuristic``; learned ``gdnet``, ``vags``, ``ggcnn``,
  ``ggcnn-close``.
"""
