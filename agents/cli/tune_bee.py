"""``flownav tune-bee``: tune the bee agent's gains by random search on training seeds only."""

from __future__ import annotations

import argparse
from pathlib import Path

HELP = "tune the bee's gains on training seeds (random search; resumable; writes ranking.md)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--candidates", type=int, default=12, help="gain sets to try (default 12)")
    parser.add_argument(
        "--seeds", type=int, default=20, help="training seeds 0..N-1 per candidate (default 20)"
    )
    parser.add_argument("--env-id", default="FlowNav-v0", help="env id (default FlowNav-v0)")
    parser.add_argument("--workers", type=int, default=2, help="local worker processes (default 2)")
    parser.add_argument(
        "--out", default="results/bee_tuning", help="output folder (default results/bee_tuning)"
    )
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="move <out>/episodes.csv to episodes.csv.bak-<time> and start a new one (nothing is deleted)",
    )


def run(args: argparse.Namespace) -> int:
    from agents.evaluation.tuning import tune_bee

    lines = tune_bee(
        args.candidates,
        args.seeds,
        Path(args.out),
        env_id=args.env_id,
        workers=args.workers,
        overwrite=args.overwrite,
    )
    print("\n".join(lines))
    return 0
