"""``flownav error-analysis``: how estimation errors cause failures, from a sweep's episodes: the tolerance table
per agent and factor and the dose-response fits (see :mod:`agents.studies.error_analysis`)."""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from agents.common.locations import RESULTS_DIR, SCRATCH_DIR

HELP = (
    "tolerance table and dose-response fits from a sweep's episodes -> error_analysis.md, dose_response.png"
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--episodes",
        default=str(RESULTS_DIR / "sweep_episodes.csv"),
        help="the sweep's episodes CSV (default: the repository's results/sweep_episodes.csv)",
    )
    parser.add_argument(
        "--baseline",
        default=str(RESULTS_DIR / "leaderboard_episodes.csv"),
        help="the clean table's episodes, the breaking points' reference (default: the repository's "
        "results/leaderboard_episodes.csv; '' for the sweep's own clean cells)",
    )
    parser.add_argument(
        "--out",
        default=str(SCRATCH_DIR / "error_analysis"),
        help=f"output folder (default %(default)s; {RESULTS_DIR} to publish)",
    )


def run(args: argparse.Namespace) -> int:
    # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
    from agents.studies.error_analysis_report import write_error_analysis_from

    command = "flownav error-analysis " + " ".join(shlex.quote(a) for a in sys.argv[2:])
    baseline = Path(args.baseline) if args.baseline else None
    print(
        "\n".join(write_error_analysis_from(Path(args.episodes), Path(args.out), command.strip(), baseline))
    )
    return 0
