"""The training pipeline's run directory: where each stage keeps its checkpoints, how far each
stage got, and the networks each stage hands to the next (and to ``eval.py``).

A run directory::

    RUN/config.json            the whole pipeline's config
    RUN/checkpoints/, metrics.jsonl       stage 1 (GDNet)            -- Stage1State
    RUN/ggcnn/                 GG-CNN (train.py --stage ggcnn): checkpoints/, config.json, metrics.json
    RUN/stage2/checkpoints/, metrics.jsonl  stage 2 (VANet, GDNet frozen) -- VagsTrainState
    RUN/stage3/checkpoints/, metrics.jsonl  stage 3 (both, alternating)  -- VagsTrainState
    RUN/nbv/checkpoints/, metrics.jsonl, networks/   the NBV baseline (train.py --stage nbv)
    RUN/timings.jsonl          wall-clock of every stage segment train.py ran

Stage order: ``ggcnn``, ``stage1``, ``stage2``, ``stage3`` (``ORDER``).  Stage 2 starts from
stage 1's final GDNet and GG-CNN; stage 3 from stage 2's final GDNet, VANet and threshold.
Stage N's checkpoint step is its iteration count, so a stage is complete when its latest
checkpoint step equals ``stageN.iterations``.
"""
from __future__ import annotations

import os
from typing import Any, Optional

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from vags_jax.ggcnn import data as ggcnn_data
from vags_jax.stages import checkpoint
from vags_jax.stages import ggcnn as ggcnn_stage
from vags_jax.stages.stage23 import final_threshold
from vags_jax.rl import dqn
from vags_jax.config import Config
from vags_jax.nets import init_qnet, make_qnet, nbv_net
from vags_jax.policies import rate_gate

ORDER = ("ggcnn", "stage1", "stage2", "stage3")
# Stages outside the pipeline's fold, trained only when asked for (train.py --stage NAME), with
# the stages they start from.
BASELINES = {"nbv": ("ggcnn", "stage1")}
ALIASES = {"gdnet": "stage1", "vanet": "stage2", "alternate": "stage3"}
DESCRIPTION = {"ggcnn": "GG-CNN on physics-labelled views", "stage1": "stage 1: GDNet",
               "stage2": "stage 2: VANet, GDNet frozen", "stage3": "stage 3: GDNet and VANet, alternating",
               "nbv": "the NBV baseline's viewpoint network"}
STAGE_SEED_SALT = {"stage1": 0, "stage2": 2, "stage3": 3, "nbv": 7}


def canonical(name: str) -> str:
    """A stage name or alias (gdnet, vanet, alternate) -> one of ``ORDER``; ValueError otherwise."""
    n = ALIASES.get(name, name)
    if n not in ORDER and n not in BASELINES:
        raise ValueError(f"unknown stage {name!r}; choose one of {', '.join(ORDER + tuple(BASELINES))} "
                         f"(aliases: {', '.join(f'{a}={b}' for a, b in ALIASES.items())})")
    return n


def stage_dir(run_dir: str, name: str) -> str:
    """Where stage ``name`` keeps its checkpoints (stage 1: the run directory itself)."""
    name = canonical(name)
    if name == "stage1":
        return run_dir
    return os.path.join(run_dir, name)


def prerequisites(name: str) -> tuple:
    """The stages that must be complete before stage ``name`` starts."""
    name = canonical(name)
    return BASELINES[name] if name in BASELINES else ORDER[:ORDER.index(name)]


def needs_ggcnn(cfg: Config) -> bool:
    """Whether the pipeline trains GG-CNN: the "ggcnn" close-view planner uses it, and
    ``vags.train_ggcnn`` asks for it anyway (the GG-CNN baselines of eval.py)."""
    return cfg.vags.local_planner == "ggcnn" or cfg.vags.train_ggcnn


def total(cfg: Config, name: str) -> int:
    """Iterations of stage ``name`` (GG-CNN: 1, it is done or not; 0 when the run does not need it)."""
    name = canonical(name)
    if name == "ggcnn":
        return 1 if needs_ggcnn(cfg) else 0
    return getattr(cfg, name).iterations


def progress(run_dir: str, name: str) -> int:
    """The latest checkpoint step of stage ``name`` in ``run_dir`` (0: not started; GG-CNN: 1
    when its checkpoint exists)."""
    d = stage_dir(run_dir, name)
    steps = checkpoint.checkpoint_steps(d) if os.path.isdir(d) else []
    if canonical(name) == "ggcnn":
        return 1 if steps else 0
    return steps[-1] if steps else 0


def stage_key(cfg: Config, name: str) -> jax.Array:
    """The PRNG key a stage starts from: ``PRNGKey(seed)`` for stage 1 (as before the pipeline
    existed), folded with the stage number for stages 2 and 3."""
    base = jax.random.PRNGKey(cfg.seed)
    salt = STAGE_SEED_SALT[canonical(name)]
    return base if salt == 0 else jax.random.fold_in(base, salt)


def learner_target(cfg: Config, kind: str) -> dqn.TrainState:
    """Host zeros shaped like a GDNet / VANet / NBV (``kind="nbv"``, ``nets.nbv_net``) learner
    of ``cfg`` (a restore target; nothing is compiled)."""
    H = cfg.workspace.heightmap_px
    net = make_qnet(nbv_net(cfg.net), "vanet") if kind == "nbv" else make_qnet(cfg.net, kind)
    shapes = jax.eval_shape(lambda k: dqn.create_train_state(init_qnet(k, net, H, H), cfg.dqn), jax.ShapeDtypeStruct((2,), jnp.uint32))
    return jax.tree.map(lambda x: np.zeros(x.shape, x.dtype), shapes)


def _need(run_dir: str, cfg: Config, name: str, for_what: str) -> int:
    """The final step of stage ``name``; CheckpointError saying what to run when it is not done."""
    done, want = progress(run_dir, name), total(cfg, name)
    if done < want:
        what = "no checkpoint" if done == 0 else f"reached iteration {done} of {want}"
        raise checkpoint.CheckpointError(
            f"{for_what} needs the end of {DESCRIPTION[name]} in {run_dir}, which has {what}: run "
            f"python train.py --out {run_dir} --resume (the whole pipeline) or --stage {name} first")
    return want


def stage1_gdnet(run_dir: str, cfg: Config, for_what: str = "stage 2") -> dqn.TrainState:
    """Stage 1's final GDNet learner (online + target + optimizer state)."""
    step = _need(run_dir, cfg, "stage1", for_what)
    learner, _ = checkpoint.restore_part(run_dir, "learner", learner_target(cfg, "gdnet"), step)
    return learner


def ggcnn_params(run_dir: str, cfg: Config, for_what: str = "stage 2"):
    """GG-CNN's parameters of the run ({"params"}); None when the run has none and does not
    need one (``needs_ggcnn``).  One the run holds is loaded even when not needed, so a stage's
    state keeps the structure its checkpoints were saved with."""
    if not needs_ggcnn(cfg) and progress(run_dir, "ggcnn") == 0:
        return None
    _need(run_dir, cfg, "ggcnn", for_what)
    params, _ = ggcnn_stage.load_ggcnn(run_dir)
    return params


def stage2_result(run_dir: str, cfg: Config, for_what: str = "stage 3"):
    """Stage 2's final (GDNet learner, VANet learner, success-net learner, threshold () float32)."""
    step = _need(run_dir, cfg, "stage2", for_what)
    d = stage_dir(run_dir, "stage2")
    gdnet = learner_target(cfg, "gdnet")  # the success net has GDNet's architecture
    got, _ = checkpoint.restore_parts(d, {"gdnet": gdnet, "vanet": learner_target(cfg, "vanet"), "success": gdnet,
                                          "threshold": np.zeros((), np.float32)}, step)
    return got["gdnet"], got["vanet"], got["success"], jnp.asarray(got["threshold"], jnp.float32)


@struct.dataclass
class VagsNetworks:
    """Everything ``eval.py --policy vags`` needs: GDNet, VANet and success-net variables
    ({"params", "batch_stats"}; success None in runs from before the success net), GG-CNN's
    {"params"}, the "q" gate's threshold () float32 (``q_threshold``; ``evaluate.vags_params``
    turns it into the configured gate's threshold), and where they came from (``source``:
    "stage3 step N" or "stage2 step N", static).  calibration: (3,) float32 the running bias
    [direct, view] of the success estimates and the mean success after a move
    (``decision.update_calibration``; (2,) in older runs, None in runs from before it was kept)."""

    gdnet: Any
    vanet: Any
    ggcnn: Any
    q_threshold: jax.Array
    success: Any = None
    calibration: Any = None
    gate_table: Any = None  # (2, K) the "rate" gate's measured table (RUN/gate.json), None without one
    close_gdnet: Any = None  # GDNet of the grasps after a move ("gdnet" planner) where it differs; None: ``gdnet``
    source: str = struct.field(pytree_node=False, default="")
    gdnet_source: str = struct.field(pytree_node=False, default="")  # GDNet's ("stage2 step N" where picked)
    close_gdnet_source: str = struct.field(pytree_node=False, default="")  # close_gdnet's; "" without one
    gate_estimate: str = struct.field(pytree_node=False, default="grasp")  # the estimate gate_table was fit on
    gate_close_score: str = struct.field(pytree_node=False, default="q")  # vags.close_score gate_table was measured with
    gate_direct_score: str = struct.field(pytree_node=False, default="q")  # vags.direct_score gate_table was measured with

    @property
    def close_source(self) -> str:
        """Where the GDNet of the grasps after a move came from (``gdnet_source`` without its own)."""
        return self.close_gdnet_source or self.gdnet_source


def networks_dir(run_dir: str, name: str) -> str:
    """Where stage 2 / 3 keep their networks alone (a few MB, no worlds or replays): the policy
    that ``eval.py --policy vags`` loads, and that can be copied to another machine."""
    return os.path.join(stage_dir(run_dir, name), "networks")


def networks_source(name: str, step: int) -> str:
    """The label of a stage's networks at a checkpoint, e.g. "stage3 step 80": ``VagsNetworks.source``,
    the reports' "networks" and the key RUN/gate.json is stored under."""
    return f"{name} step {step}"


def vags_stages(run_dir: str) -> list:
    """The stages ("stage3", "stage2") whose networks the run has saved, latest first."""
    return [n for n in ("stage3", "stage2") if os.path.isdir(networks_dir(run_dir, n))
            and checkpoint.checkpoint_steps(networks_dir(run_dir, n))]


def save_networks(run_dir: str, name: str, step: int, state, cfg: Config) -> str:
    """Writes the GDNet, VANet and success-net variables and the "q" gate's threshold of a
    ``VagsTrainState`` at ``step`` to ``networks_dir`` -> that directory.  After stage 3 the
    threshold is re-set on its last views (``vags_stages.final_threshold``): GDNet changed."""
    as_vars = lambda ts: {"params": ts.params, "batch_stats": ts.batch_stats}  # noqa: E731
    thr = final_threshold(state, cfg.vags) if name == "stage3" else state.threshold
    d = networks_dir(run_dir, name)
    checkpoint.save(d, step, {"gdnet": as_vars(state.gdnet), "vanet": as_vars(state.vanet),
                              "success": as_vars(state.success), "threshold": thr,
                              "calibration": state.calibration})
    return d


def vars_target(cfg: Config, kind: str) -> dict:
    """Host zeros shaped like a GDNet / VANet / NBV network's variables ({"params", "batch_stats"}
    of ``learner_target``): what a run's networks are restored into."""
    ts = learner_target(cfg, kind)
    return {"params": ts.params, "batch_stats": ts.batch_stats}


# The GDNets a run with stage-3 networks can play (``vags.stage3_gdnet_pick``), as (the direct
# grasps' GDNet, the close-view grasps' GDNet): "split" grasps directly with stage 2's GDNet and
# after a move with stage 3's, which learned on the fused close-view maps.
GDNET_PICKS = {"stage3": ("stage3", "stage3"), "stage2": ("stage2", "stage2"), "split": ("stage2", "stage3")}


def load_vags(run_dir: str, cfg: Optional[Config] = None, step: Optional[int] = None,
              stage: Optional[str] = None, gdnet: Optional[str] = None) -> VagsNetworks:
    """The latest VAGS networks of a run: stage 3's (checkpoint ``step``, default its latest)
    when stage 3 saved any, else stage 2's, or those of ``stage`` ("stage2" / "stage3"); read
    from the stage's ``networks/`` directory, and GG-CNN from RUN/ggcnn (None when the run has
    none).  With stage 3's networks, ``gdnet`` (a ``GDNET_PICKS`` key; None: what RUN/gate.json
    picked, ``stage3_gdnet_pick``) says whose GDNet grasps directly and after a move; the "q"
    threshold comes with the direct grasps' GDNet.  CheckpointError (one line, what to run)
    when there are none."""
    cfg = checkpoint.load_config(run_dir) if cfg is None else cfg
    found = vags_stages(run_dir)
    if not found:
        raise checkpoint.CheckpointError(
            f"run {run_dir} has no VANet yet (no stage 2 or 3 networks): train it with "
            f"python train.py --out {run_dir} --resume (or --stage stage2)")
    if stage is not None and stage not in found:  # stage 3 not trained yet, or stage 2's not kept
        hint = f": train it with python train.py --out {run_dir} --resume" if stage == "stage3" else ""
        raise checkpoint.CheckpointError(f"run {run_dir} has no {stage} networks (it has {', '.join(found)}'s){hint}")
    if gdnet is not None and gdnet not in GDNET_PICKS:
        raise ValueError(f"gdnet must be one of {tuple(GDNET_PICKS)}, got {gdnet!r}")
    name = found[0] if stage is None else stage
    if gdnet == "split" and name != "stage3":
        raise checkpoint.CheckpointError(f"run {run_dir}: the 'split' GDNets need stage 3's networks, and it has "
                                         f"{name}'s: train stage 3 with python train.py --out {run_dir} --resume")
    gd, va, thr, su, cal, s = _restore_vags(run_dir, cfg, name, step)
    source = gd_source = networks_source(name, s)
    close, close_source = None, ""
    pick = (gdnet or picked_gdnet(run_dir, cfg, source)) if name == "stage3" else "stage3"  # stage 2's own
    direct_from, close_from = GDNET_PICKS[pick]
    if "stage2" in (direct_from, close_from):
        if "stage2" not in found:
            raise checkpoint.CheckpointError(f"run {run_dir} keeps no stage-2 networks, whose GDNet was asked for")
        gd3 = gd
        gd, _, thr, _, _, s2 = _restore_vags(run_dir, cfg, "stage2", None)
        gd_source = networks_source("stage2", s2)
        if close_from == "stage3":
            close, close_source = gd3, source
    gg = None
    if os.path.isdir(ggcnn_stage.ggcnn_dir(run_dir)):
        gg, _ = ggcnn_stage.load_ggcnn(run_dir)
    table = rate_gate.load(run_dir, source, gd_source, close_source or gd_source, cfg.vags.max_motion_number,
                           cfg.vags.cap_split, cfg.vags.gate_min_z)
    return VagsNetworks(gdnet=gd, vanet=va, ggcnn=gg, q_threshold=jnp.asarray(thr, jnp.float32), success=su,
                        calibration=cal, gate_table=table,
                        close_gdnet=close, source=source, gdnet_source=gd_source, close_gdnet_source=close_source,
                        gate_estimate=rate_gate.estimate_of(run_dir) if table is not None else "grasp",
                        gate_close_score=rate_gate.close_score_of(run_dir) if table is not None else "q",
                        gate_direct_score=rate_gate.direct_score_of(run_dir) if table is not None else "q")


def _restore_vags(run_dir: str, cfg: Config, name: str, step: Optional[int]):
    """One stage's saved networks -> (gdnet, vanet, threshold, success, calibration, step)."""
    gdnet = vars_target(cfg, "gdnet")  # the success net has GDNet's architecture
    # success: absent in runs from before the success net; calibration (3,), (2,) in runs from
    # before the mean success after a move was kept, so it is read as saved.
    got, s = checkpoint.restore_parts(networks_dir(run_dir, name),
                                      {"gdnet": gdnet, "vanet": vars_target(cfg, "vanet"),
                                       "threshold": np.zeros((), np.float32), "success": gdnet,
                                       "calibration": None}, step, optional=("success", "calibration"))
    cal = None if got["calibration"] is None else jnp.asarray(
        np.ravel(next(iter(got["calibration"].values()))), jnp.float32)
    return got["gdnet"], got["vanet"], got["threshold"], got["success"], cal, s


def picked_gdnet(run_dir: str, cfg: Config, source: str) -> str:
    """The ``GDNET_PICKS`` key RUN/gate.json, measured on stage-3 networks ``source``, kept
    (``vags.stage3_gdnet_pick="rate"``): "stage2", "split" (its "close_gdnet" is stage 3's), else
    "stage3"."""
    d = rate_gate.read(run_dir) if cfg.vags.stage3_gdnet_pick == "rate" else None
    if d is None or d.get("networks") != source:
        return "stage3"
    direct = str(d.get("gdnet", source)).split(" ")[0]
    close = str(d.get("close_gdnet", d.get("gdnet", source))).split(" ")[0]
    return next((k for k, v in GDNET_PICKS.items() if v == (direct, close)), "stage3")


def load_nbv(run_dir: str, cfg: Optional[Config] = None) -> VagsNetworks:
    """The NBV baseline of a run (``train.py --stage nbv``): its viewpoint network as ``vanet``,
    the GDNet it trained beside (the "gdnet" close-view planner's) and the run's GG-CNN;
    CheckpointError (one line, what to run) when it has none."""
    cfg = checkpoint.load_config(run_dir) if cfg is None else cfg
    d = networks_dir(run_dir, "nbv")
    if not (os.path.isdir(d) and checkpoint.checkpoint_steps(d)):
        raise checkpoint.CheckpointError(f"run {run_dir} has no NBV network yet: train it with "
                                         f"python train.py --out {run_dir} --stage nbv")
    got, s = checkpoint.restore_parts(d, {"gdnet": vars_target(cfg, "gdnet"), "vanet": vars_target(cfg, "nbv")})
    gd, va = got["gdnet"], got["vanet"]
    gg = None
    if os.path.isdir(ggcnn_stage.ggcnn_dir(run_dir)):
        gg, _ = ggcnn_stage.load_ggcnn(run_dir)
    return VagsNetworks(gdnet=gd, vanet=va, ggcnn=gg, q_threshold=jnp.asarray(jnp.inf, jnp.float32),
                        source=networks_source("nbv", s), gdnet_source=networks_source("nbv", s))


def ggcnn_reusable(run_dir: str, cfg: Config) -> Optional[str]:
    """For a new pipeline in ``run_dir``: None when it holds no GG-CNN, or one trained on the
    same data and GG-CNN settings as ``cfg`` (it is reused); else a message saying why not."""
    gdir = ggcnn_stage.ggcnn_dir(run_dir)
    if not (os.path.isdir(gdir) and checkpoint.checkpoint_steps(gdir)):
        return None
    old = checkpoint.load_config(gdir)  # saved before ggcnn.labels: GG-CNN's positives (LEGACY_FIELDS)
    if ggcnn_data.data_hash(old) != ggcnn_data.data_hash(cfg) or old.ggcnn != cfg.ggcnn:
        return (f"{gdir} holds a GG-CNN trained with another config (its data or ggcnn section differ); "
                f"delete {gdir} or choose another --out")
    return None



def load_gdnet(run_dir: str, step: Optional[int] = None):
    """Restores only the GDNet learner of a stage-1 run -> ``(run_cfg, variables, step)``.

    ``variables`` = ``{"params", "batch_stats"}`` of the online network.  Checkpoints store each
    part of ``Stage1State`` under its name, so only ``learner`` is read: the worlds and the replay
    buffer (gigabytes at scale) are neither built nor loaded.
    Raises ``checkpoint.CheckpointError`` (a ValueError) with what to fix.
    """
    cfg = checkpoint.load_config(run_dir) if os.path.isdir(run_dir) else None
    if cfg is None:
        raise checkpoint.CheckpointError(f"run directory {run_dir!r} does not exist")
    learner, step = checkpoint.restore_part(run_dir, "learner", learner_target(cfg, "gdnet"), step)
    return cfg, {"params": learner.params, "batch_stats": learner.batch_stats}, step


__all__ = ["picked_gdnet", "GDNET_PICKS", "ORDER", "BASELINES", "prerequisites", "load_nbv", "ALIASES", "DESCRIPTION", "canonical", "stage_dir", "total", "progress", "stage_key", "vars_target",
           "learner_target", "stage1_gdnet", "needs_ggcnn", "ggcnn_params", "stage2_result", "VagsNetworks",
           "load_vags", "networks_dir", "save_networks", "ggcnn_reusable", "load_gdnet"]
