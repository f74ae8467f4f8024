"""``eval.py``'s command-line flags (``add_eval_arguments``); what they ask for is checked by
``vags_jax.benchmark.requests.prepare_eval`` before anything is compiled."""
from __future__ import annotations

import argparse

from vags_jax import cli


def add_eval_arguments(p: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """Adds every flag of ``eval.py`` to ``p`` -> ``p``."""
    p.add_argument("--run", default=None, help="run directory written by train.py (config.json + checkpoints/)")
    p.add_argument("--policy", default=None,
                   help="vags | gdnet | ggcnn | ggcnn-close | vpg | random | highest | heuristic (default: vags for "
                        "a run with stage 2 or 3, gdnet for a stage-1 run, else heuristic)")
    p.add_argument("--threshold", type=float, default=None,
                   help="vags: the decision threshold (default: the run's, stored by stage 2)")
    p.add_argument("--no-viewpoint", action="store_true",
                   help="vags without VANet: always grasp directly with its GDNet (threshold -inf)")
    p.add_argument("--threshold-sweep", default=None, metavar="A:B:STEP",
                   help="vags: also evaluate at each threshold A, A+STEP, ..., B (e.g. 1.70:1.80:0.01)")
    p.add_argument("--quantile-sweep", default=None, metavar="A:B:STEP",
                   help="vags: also evaluate at these quantiles (0..1) of the largest GDNet Q seen at the "
                        "main run's decisions (e.g. 0:1:0.1)")
    p.add_argument("--plot", default=None, metavar="PATH.png",
                   help="success and clearing vs objects (paper Fig. 7); needs matplotlib")
    p.add_argument("--compare", nargs="*", default=[], metavar="METHOD",
                   help="Table 1: play every METHOD on the same scenes and seed (and --policy first, when given); "
                        "a METHOD is a policy name (networks from --run), a run directory (its default policy), "
                        "RUN:policy, or a report .json of eval.py (same seed, groups and rounds)")
    p.add_argument("--record", default=None, metavar="DIR",
                   help="vags: pictures of the first --record-rounds rounds of each group")
    p.add_argument("--record-rounds", type=cli.int_in(1, 1000), default=1,
                   help="rounds per group that --record draws (default 1)")
    p.add_argument("--config", default=None, help="preset when there is no --run: tiny | gpu | gpu-edge | paper | default (default: tiny)")
    p.add_argument("--set", nargs="*", default=[], metavar="SECTION.FIELD=VALUE",
                   help="evaluation config overrides, e.g. scene.max_objects=10 benchmark.max_attempts_extra=5")
    p.add_argument("--groups", default=None,
                   help="object counts: 1,2,3 or 1-10 or 1-3,5 (default: benchmark.groups, else 1..scene.max_objects)")
    p.add_argument("--rounds", type=cli.int_in(1, 1 << 20), default=None,
                   help="rounds per group = parallel worlds (default: benchmark.rounds, 50)")
    p.add_argument("--seed", type=cli.int_in(0, 2**32 - 1), default=None,
                   help="PRNG seed (default: the config's seed)")
    p.add_argument("--seeds", default=None, metavar="S1,S2,...",
                   help="several seeds, each a full table, compiled once: --out must hold {seed} (default: "
                        "RUN/eval_<policy>_seed<S>.json); prints each seed's overall figures and their mean")
    p.add_argument("--step", type=cli.int_in(0), default=None,
                   help="checkpoint step for gdnet, vags or vpg (default: latest)")
    p.add_argument("--networks", default=None, choices=("stage2", "stage3"),
                   help="vags: the networks saved after this stage (default: the latest). Stage 2's GDNet "
                        "is stage 1's, which stage 3 goes on training")
    p.add_argument("--out", default=None, help="JSON report path (default: RUN/eval_<policy>.json)")
    p.add_argument("--speed", type=cli.positive_float(100.0), default=None,
                   help="motion-time model: gripper speed m/s (default benchmark.speed, 0.5)")
    p.add_argument("--objects", default=None, choices=("train", "unseen", "legacy"),
                   help="object set of the scenes (default: the config's pool; 'unseen': the held-out "
                        "shapes, never trained on)")
    p.add_argument("--scenes", default=None, choices=("paper", "edge", "legacy"),
                   help="'edge': the variant with piles up to the workspace edges and a global view that "
                        "just holds the workspace (docs/benchmark.md); 'legacy': the first benchmark's "
                        "scenes (fixed blocks scattered apart, noiseless camera from the old pose), for "
                        "comparisons with earlier results")
    cli.add_cache_dir(p)
    p.add_argument("--verbose", action="store_true",
                   help="show third-party logs (Warp kernel loading, absl / orbax INFO), silenced by default")
    return p
