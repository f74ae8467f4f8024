"""Configuration: frozen dataclasses for every part of vags_jax, their checks, and the presets.

* ``sections``: one dataclass per concern (``Workspace``, ``Scene``, ``Sim``, ``Grasp``,
  ``Camera``, ``Net``, ``DQN``, ``Replay``, ``Exploration``, ``Stage``, ``Vags``, GG-CNN's,
  ``Benchmark``, the baselines' ``Mvp``, ``Vpg`` and ``Push``, data-parallel ``Parallel``, the rate gate's ``GateTable``) and
  the whole ``Config``; the conventions every module shares (frames,
  heightmap axes, rotations) are stated at its top.
* ``validation``: type checks driven by the field annotations (``@checked``).
* ``overrides``: ``replace`` with dotted keys (``--set``), ``to_dict`` / ``from_dict`` (``from_saved``:
  a run's config.json, older fields filled as those runs trained).
* ``presets``: ``tiny`` (CPU), ``gpu``, ``gpu-edge``, ``paper``, ``default``.

Everything is re-exported here: ``from vags_jax import config as C; C.replace(C.tiny(), ...)``.
"""
from vags_jax.config.overrides import (LEGACY_FIELDS, from_dict, from_saved, parse_overrides, replace, to_dict,
                                       without_iterations)
from vags_jax.config.presets import PRESETS, gpu, gpu_edge, paper, preset, tiny
from vags_jax.config.sections import (MAX_HEIGHTMAP_PX, MAX_IMAGE_SIDE, MAX_WORLDS,
                                      MAX_DEVICE_BYTES, REPLAY_BYTES_PER_CELL, Workspace,
                                      OBJECT_SETS, object_pool, PLACEMENTS, EDGE_SCENES,
                                      LEGACY_SCENES, Scene, Sim, Grasp, DepthNoise, Camera, Net,
                                      DQN, Replay, Exploration, Stage, STAGE_BOOTSTRAPS, VAGS_LOCAL_PLANNERS,
                                      VAGS_GATES, VAGS_VIEW_REWARDS, VAGS_VIEW_ESTIMATES, VAGS_VIEWPOINTS, VAGS_STAGE3_GDNET, VAGS_STAGE3_GDNET_PICKS, VAGS_CLOSE_REGIONS, VAGS_GATE_ESTIMATES, Vags, GGCNN_SIZE_MULTIPLE,
                                      GGCNN_ROTATIONS, GGCNN_LABELS, GGCNNConfig, GGCNNData,
                                      Benchmark, Mvp, Push, Vpg, Parallel, GateTable, Config, benchmark_groups, check_vpg_fits,
                                      DEFAULT_REDROPS, spilled_remedy,
                                      ggcnn_object_range)
