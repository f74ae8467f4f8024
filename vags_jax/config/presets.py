"""Presets: ``tiny`` (a CPU run in minutes), ``gpu`` (one H100/H200), ``gpu-edge``, ``paper``,
``default``.  The measurements behind each choice are in bench/RESULTS.md."""
from __future__ import annotations

from vags_jax.config.overrides import replace
from vags_jax.config.sections import (DQN, EDGE_SCENES, Camera, Config, Exploration, GateTable, GGCNNConfig, GGCNNData, Grasp,
                                      Net, Replay, Scene, Sim, Stage, Vags, Vpg, Workspace, object_pool)



def tiny() -> Config:
    """Runs on a laptop CPU in a few minutes: small images, small heightmaps, tiny nets."""
    return Config(
        workspace=Workspace(heightmap_px=32),
        # Three slots of the training set (2 boxes, 1 capsule of drawn sizes), piled, 1 s settle.
        scene=Scene(max_objects=3, shapes=object_pool("train", 3), copies_per_shape=1),
        # impratio 1: under MJX jax, 10 sent fresh worlds to NaN (bench/RESULTS.md, "Environment throughput",
        # 5th pass).
        sim=Sim(impratio=1.0),
        camera=Camera(width=128, height=96, fx=123.7, fy=123.7),
        net=Net(trunk="small", small_width=8),
        dqn=DQN(batch_size=8, optimizer="adam", learning_rate=1e-3, target_update_period=20),
        replay=Replay(capacity=512),
        exploration=Exploration(eps_decay=0.99),
        stage1=Stage(n_worlds=4, iterations=40, min_objects=1, max_objects=3, learning_starts=8),
        stage2=Stage(name="vanet", n_worlds=4, iterations=20, min_objects=1, max_objects=3, learning_starts=8),
        stage3=Stage(name="alternate", n_worlds=4, iterations=20, min_objects=1, max_objects=3, learning_starts=8),
        nbv=Stage(name="nbv", n_worlds=4, iterations=20, min_objects=1, max_objects=3, learning_starts=8),
        # GG-CNN at 24 x 24 (the 96-pixel square of the 128 x 96 image, resized by 1/4).
        ggcnn=GGCNNConfig(input_size=24, inpaint_iters=16, quality_sigma=1.0, train_steps=60),
        ggcnn_data=GGCNNData(views=16, heldout_views=8, candidates=8, scenes_per_batch=4),
        # VPG's change threshold scaled to the 32 x 32 heightmap: 300 of 224 x 224 cells ~ 6 of 32 x 32.
        vpg=Vpg(n_worlds=4, iterations=20, min_objects=1, max_objects=3, learning_starts=8, change_cells=6),
        gate_table=GateTable(worlds=4, steps=2, bins=2),
    )


def gpu() -> Config:
    """One H100/H200, impl "warp" and the Warp renderer: the learning settings of the stage-1 runs in
    bench/RESULTS.md (512 worlds, small trunk in bf16, 16 updates of batch 64 per iteration)
    and the faster physics settings measured there (6 ms step, solver cap 2, 96 contacts per
    world, primitive box-box collisions, 0.05 s of settling after a grasp, a lift with no
    pause at the top, 0.85 s of settling after a reset)."""
    return Config(
        # Physics settings measured on one H100 (bench/RESULTS.md, "Environment throughput", 3rd to 8th pass): 6
        # ms step, solver cap 2,
        # 96 contacts per world, primitive box-box, 0.05 s after the lift, no pause at the top, 0.85 s settle.
        sim=Sim(impl="warp", timestep=0.006, iterations=2, contacts_per_world=96, native_ccd=False),
        scene=Scene(settle_time=0.85),
        # MJX's Warp renderer, 512 worlds a batch: the pipeline 0.86x the ray caster's wall clock, the same
        # learning within 2 points (bench/RESULTS.md, "The `gpu` preset takes the Warp renderer").
        camera=Camera(renderer="warp", render_batch=512),
        grasp=Grasp(t_post=0.05, t_lift=0.375, lift_hold=0.0),
        # Q-network passes only where used: stage 1 1.10x faster an iteration, its peak memory 50.4 -> 32.5 GiB
        # (bench/RESULTS.md, "Q-network passes only where their result is used").
        net=Net(trunk="small", small_width=32, dtype="bfloat16", forward_needed_only=True),
        dqn=DQN(batch_size=64, optimizer="adam", learning_rate=5e-4, target_update_period=50),
        replay=Replay(capacity=16_384),
        exploration=Exploration(eps_decay=0.97),
        # Stage lengths: the pipeline fits well under 30 minutes of one H100 (bench/RESULTS.md, "VAGS end to end").
        stage1=Stage(n_worlds=512, iterations=120, min_objects=1, max_objects=5,
                     updates_per_iteration=16, learning_starts=1024),
        stage2=Stage(name="vanet", n_worlds=512, iterations=80, min_objects=1, max_objects=10,
                     updates_per_iteration=16, learning_starts=512),
        stage3=Stage(name="alternate", n_worlds=512, iterations=80, min_objects=1, max_objects=10,
                     updates_per_iteration=16, learning_starts=512),
        # NBV (train.py --stage nbv): stage 2's budget, for one viewpoint network.
        nbv=Stage(name="nbv", n_worlds=512, iterations=80, min_objects=1, max_objects=10,
                  updates_per_iteration=16, learning_starts=512),
        # GG-CNN: 4,096 + 512 views of 64 candidates (bench/RESULTS.md, "Close views and GG-CNN").
        ggcnn=GGCNNConfig(batch_size=32, train_steps=6000),
        ggcnn_data=GGCNNData(views=4096, heldout_views=512, candidates=64, scenes_per_batch=64),
        # VPG (train.py --stage vpg): scenes of 1-10 objects as VPG's; stage 1's worlds and updates.
        vpg=Vpg(n_worlds=512, iterations=100, min_objects=1, max_objects=10, updates_per_iteration=16,
                learning_starts=1024),
        # The "rate" gate (table measured after stage 3; stage 3 trains with "success"): on three trained runs
        # 86.2-86.3 % success against 83.7-87.0 % (bench/RESULTS.md, "Viewpoints that pay, sixth look").
        # The grasp after a move scored by the success net: after-move grasps 89-93 % instead of 62-68 % in
        # the benchmark's rounds ("twenty-fifth look").
        vags=Vags(gate="rate", close_score="success"),
        # 512 piles x 8 attempts: 256 x 4's bins were noisy enough to flip a bin's choice (RESULTS, "eighth look").
        gate_table=GateTable(worlds=512, steps=8),
    )


def paper() -> Config:
    """Paper-faithful: DenseNet-121 trunks, SGD 1e-4, one robot's worth of updates."""
    return Config(sim=Sim(impl="warp"), net=Net(trunk="densenet121", dtype="bfloat16"))


def gpu_edge() -> Config:
    """The ``gpu`` preset on the "edge" scene variant (``EDGE_SCENES``)."""
    return replace(gpu(), **EDGE_SCENES)


PRESETS = {"tiny": tiny, "gpu": gpu, "gpu-edge": gpu_edge, "paper": paper, "default": Config}


def preset(name: str) -> Config:
    if name not in PRESETS:
        raise ValueError(f"unknown config preset {name!r}; choose one of {sorted(PRESETS)}")
    return PRESETS[name]()
