"""``flownav select``: each finished training seed's policy chosen among finalists on 50 more validation layouts
(see :mod:`agents.studies.selection`), optionally shipped again."""

from __future__ import annotations

import argparse
from pathlib import Path

from agents.common.locations import POLICIES_DIR
from agents.common.yaml_config import load_config
from agents.training.outputs import RunFiles
from agents.training.train_config import TrainConfig

HELP = "choose each finished seed's policy among its finalists on 50 more validation layouts (resumable)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", required=True, help="the training config, e.g. configs/ppo_flow.yaml")
    parser.add_argument("--seeds", default="0", help="training seeds, e.g. 0-4 or 0,3 (default: %(default)s)")
    parser.add_argument("--runs-dir", default="runs", help="where the seeds' runs are (default: %(default)s)")
    parser.add_argument(
        "--workers", type=int, default=2, help="local worker processes (default: %(default)s)"
    )
    parser.add_argument("--ship", action="store_true", help="ship each chosen policy (all files together)")
    parser.add_argument(
        "--ship-to", default=str(POLICIES_DIR), help=f"policies folder (default {POLICIES_DIR}/<name>)"
    )


def run(args: argparse.Namespace) -> int:
    # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
    from agents.studies.selection import select_finalist
    from agents.training.multiseed import parse_seeds
    from agents.training.shipping import ship_run

    if args.workers < 1:
        raise ValueError(f"--workers must be >= 1, got {args.workers}")
    config = load_config(Path(args.config), TrainConfig)
    for seed in parse_seeds(args.seeds):
        files = RunFiles.of_seed(Path(args.runs_dir), config.name, seed)
        print(f"seed {seed}: {select_finalist(files, seed, workers=args.workers)}")
        if args.ship:
            ship_run(files, Path(args.ship_to) / config.name)
    return 0
