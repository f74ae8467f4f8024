"""Training: the stages of the paper, the pipeline that chains them, and the run directory.

* ``stage1``: GDNet alone.  ``stage23``: stage 2 (VANet, GDNet frozen) and stage 3 (both).
  ``ggcnn``: GG-CNN on physics-labelled views.  Each offers ``make_stage(cfg, env) ->
  StageFns(init, run, output)``.
* ``pipeline``: the pipeline as a fold over stages (``train_in_memory``), and the same fold with
  checkpoints as a side effect at chunk boundaries (``train_run``).
* ``rundir``: where each stage keeps its checkpoints and networks; ``checkpoint``: orbax I/O.
* ``requests``: the checks ``train.py`` makes before anything is built.
"""
