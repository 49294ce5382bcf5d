"""``flownav train``: PPO on FlowNav from a YAML config (see :mod:`agents.training.ppo`)."""

from __future__ import annotations

import argparse
from pathlib import Path

HELP = "train a PPO policy from a YAML config (resumable)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", required=True, help="training config YAML, e.g. configs/ppo_flow.yaml")
    parser.add_argument(
        "--resume", action="store_true", help="continue from the newest checkpoint of the run"
    )
    parser.add_argument("--runs-dir", default="runs", help="logs and checkpoints (default runs/)")
    parser.add_argument("--policies-dir", default="results/policies", help="where the trained policy goes")
    parser.add_argument("--total-timesteps", type=int, help="override the config's total_timesteps")
    parser.add_argument("--max-minutes", type=float, help="override the config's wall-clock budget")


def run(args: argparse.Namespace) -> int:
    from agents.common.config import check_env_kwargs, load_config
    from agents.training.config import TrainConfig
    from agents.training.ppo import train

    config_path = Path(args.config)
    config = load_config(config_path, TrainConfig)
    if args.total_timesteps is not None:
        config.total_timesteps = args.total_timesteps
    if args.max_minutes is not None:
        config.max_minutes = args.max_minutes
    check_env_kwargs(config.env, str(config_path))
    train(
        config,
        config_path=config_path,
        resume=args.resume,
        runs_dir=Path(args.runs_dir),
        policies_dir=Path(args.policies_dir),
    )
    return 0
