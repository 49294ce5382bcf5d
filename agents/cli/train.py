"""``flownav train``: PPO on FlowNav from a YAML config (see :mod:`agents.training.ppo`).

A run writes only under ``<runs-dir>/<name>/``: policy, config copy, record, evaluations, learning curve,
checkpoints and TensorBoard logs. Shipping it to the policies folder that the benchmark flies
(``results/policies/``) is deliberate: ``--ship`` at the end of training, or ``--ship-only`` for a finished run.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from agents.common.paths import POLICIES_DIR

HELP = "train a PPO policy from a YAML config into runs/<name>/ (resumable; --ship to publish it)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", required=True, help="training config YAML, e.g. configs/ppo_flow.yaml")
    parser.add_argument(
        "--resume",
        action="store_true",
        help="continue from the newest readable checkpoint of the run. Checkpoints are loaded with "
        "PPO.load, which unpickles them and so can run code: resume only runs you made yourself",
    )
    parser.add_argument(
        "--runs-dir", default="runs", help="the run's outputs go to RUNS_DIR/<name>/ (default runs/)"
    )
    parser.add_argument(
        "--ship",
        action="store_true",
        help="after training (unless interrupted), copy the run's policy, config, record, evaluations and "
        "curve to --ship-to and update its MANIFEST.sha256",
    )
    parser.add_argument(
        "--ship-only",
        action="store_true",
        help="do not train: ship the finished run of --config to --ship-to",
    )
    parser.add_argument(
        "--ship-to", default=str(POLICIES_DIR), help=f"policies folder to ship to (default {POLICIES_DIR})"
    )
    parser.add_argument("--total-timesteps", type=int, help="override the config's total_timesteps")
    parser.add_argument("--max-minutes", type=float, help="override the config's wall-clock budget")


def run(args: argparse.Namespace) -> int:
    from agents.common.config import check_env_kwargs, load_config
    from agents.training.config import TrainConfig, override
    from agents.training.outputs import RunFiles
    from agents.training.ppo import train
    from agents.training.shipping import ship_run

    config_path = Path(args.config)
    config = load_config(config_path, TrainConfig)
    if args.ship_only:
        if args.resume or args.ship or args.total_timesteps is not None or args.max_minutes is not None:
            raise ValueError("--ship-only ships a finished run: it takes no training options")
        ship_run(RunFiles.of(Path(args.runs_dir), config.name), Path(args.ship_to))
        return 0
    override(config, "total_timesteps", args.total_timesteps, "--total-timesteps")
    override(config, "max_minutes", args.max_minutes, "--max-minutes")
    check_env_kwargs(config.env, str(config_path))
    train(
        config,
        config_path=config_path,
        resume=args.resume,
        runs_dir=Path(args.runs_dir),
        ship_to=Path(args.ship_to) if args.ship else None,
    )
    return 0
