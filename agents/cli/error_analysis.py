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
        action="append",
        help="a sweep's episodes CSV, repeatable: one per suite tier it flew (default: the repository's "
        "results/sweep_episodes.csv)",
    )
    parser.add_argument(
        "--baseline",
        help="the clean episodes, the breaking points' reference: the suite's (results/suite_episodes.csv) for a "
        "sweep on the current suite's tiers, else the clean table's (default: results/leaderboard_episodes.csv); "
        "'' for the sweep's own clean cells (default: by the episodes' task)",
    )
    parser.add_argument(
        "--compare-with",
        nargs=2,
        metavar=("EPISODES_CSV", "BASELINE_CSV"),
        help="an earlier sweep's episodes and its clean table's: each clean-tier tolerance is set beside it",
    )
    parser.add_argument(
        "--out",
        default=str(SCRATCH_DIR / "error_analysis"),
        help=f"output folder (default %(default)s; {RESULTS_DIR} to publish)",
    )


def run(args: argparse.Namespace) -> int:
    # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
    from agents.reports.error_analysis_report import default_baseline, write_error_analysis_from

    command = "flownav error-analysis " + " ".join(shlex.quote(a) for a in sys.argv[2:])
    episodes = episode_files(args)
    baseline = default_baseline(episodes) if args.baseline is None else args.baseline
    compare = None if args.compare_with is None else (Path(args.compare_with[0]), Path(args.compare_with[1]))
    lines = write_error_analysis_from(
        episodes, Path(args.out), command.strip(), Path(baseline) if baseline else None, compare_with=compare
    )
    print("\n".join(lines))
    return 0


def episode_files(args: argparse.Namespace) -> list[Path]:
    """The sweep episodes CSVs the command reads: each ``--episodes`` given, else the repository's
    ``results/sweep_episodes.csv`` (a default outside argparse, since an appending option adds to its default)."""
    return [Path(path) for path in args.episodes or [RESULTS_DIR / "sweep_episodes.csv"]]
