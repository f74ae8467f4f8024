"""The benchmark (paper section 4.4): rounds, metrics, time model, reports, pictures.

* ``protocol``: ``Evaluator`` (all rounds of all groups in one jitted loop) and ``evaluate``.
* ``metrics``: ``RoundOutcomes``, ``summarize``, ``MotionTimeModel``, the Markdown table.
* ``reports``: CSV files and plots; ``sweep``: threshold sweeps.
* ``record``, ``record_rounds``, ``images``: pictures of recorded VAGS rounds.
* ``arguments``: ``eval.py``'s flags; ``requests``: the checks ``eval.py`` makes before anything
  is compiled.
"""
