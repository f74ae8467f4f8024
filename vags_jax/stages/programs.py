"""The programs one process builds, by config: the environment, the training stages, VPG's stage
and GG-CNN's data makers, each compiled once and shared by every ``train`` call, stage and gate
measurement that is handed the same ``Programs``."""
from __future__ import annotations

from typing import Callable

from vags_jax import config as C
from vags_jax.env import VagsEnv
from vags_jax.ggcnn import data as ggcnn_data
from vags_jax.stages import pipeline
from vags_jax.stages import vpg as vpg_stage
from vags_jax.stages.data_parallel import DataParallelStage1
from vags_jax.stages.stage1 import Stage1
from vags_jax.stages.stage23 import VagsStage


class Programs:
    """The environment, stages and GG-CNN data makers built in this process, by config (the
    iteration counts do not enter the programs, so they are not part of the key).  Pass one
    ``Programs`` to several ``train`` calls to compile each program once."""

    def __init__(self):
        self._built: dict = {}

    def get(self, key, make: Callable):
        if key not in self._built:
            self._built[key] = make()
        return self._built[key]

    def cfg_key(self, kind: str, cfg):
        return kind, C.without_iterations(cfg)

    def env(self, cfg) -> VagsEnv:
        return self.get(self.cfg_key("env", cfg), lambda: VagsEnv(cfg))

    def stage(self, name: str, cfg):
        """The built ``Stage1`` / ``VagsStage`` of ``name`` for ``cfg`` on this process's env
        (stage 1 over ``parallel.devices`` > 1 devices: ``DataParallelStage1``)."""
        if name == "stage1":
            make = (lambda: DataParallelStage1(cfg, self.env(cfg))) if cfg.parallel.devices > 1 else (
                lambda: Stage1(cfg, self.env(cfg)))
        else:
            make = lambda: self._share_program(VagsStage(cfg, pipeline.which_stage(name), self.env(cfg)))  # noqa: E731
        return self.get(self.cfg_key(name, cfg), make)

    def _share_program(self, stage: VagsStage) -> VagsStage:
        """Stages 2 and 3 of one config usually build the same chunk program (their switches are
        traced): the second one built runs the first one's, so it compiles nothing."""
        first = self.get(("vags_program", stage.program_key()), lambda: stage)
        if first is not stage:
            stage.use_program_of(first)
        return stage

    def vpg(self, cfg) -> vpg_stage.VpgStage:
        """VPG's built stage for ``cfg`` on this process's env."""
        return self.get(self.cfg_key("vpg", cfg), lambda: vpg_stage.VpgStage(cfg, self.env(cfg)))

    def data_maker(self, cfg) -> ggcnn_data.DataMaker:
        """GG-CNN's data programs, shared by configs with the same ``program_key``."""
        return self.get(("ggcnn_data", ggcnn_data.program_key(cfg)), lambda: ggcnn_data.DataMaker(cfg))


__all__ = ["Programs"]
