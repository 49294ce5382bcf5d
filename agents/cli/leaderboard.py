"""``flownav leaderboard``: every agent on the same clean test layouts, learned agents over all their shipped
training seeds; writes the leading table of the benchmark (see :mod:`agents.evaluation.leaderboard`)."""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from agents.common.locations import POLICIES_DIR, RESULTS_DIR

HELP = "fly every agent (learned ones over their training seeds) on the test layouts; write the leading table"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from agents.evaluation.leaderboard import MIN_EPISODES
    from agents.policies import AGENT_NAMES

    parser.add_argument(
        "--agents",
        default=",".join(AGENT_NAMES),
        help=f"comma-separated agents (default: all, {','.join(AGENT_NAMES)})",
    )
    parser.add_argument(
        "--episodes", type=int, default=MIN_EPISODES, help="test layouts per run (default: %(default)s)"
    )
    parser.add_argument(
        "--workers", type=int, default=2, help="local worker processes (default: %(default)s)"
    )
    parser.add_argument("--policies-dir", default=str(POLICIES_DIR), help="where the seeds' policies are")
    parser.add_argument(
        "--out",
        default="runs/leaderboard",
        help=f"output folder (default runs/leaderboard; {RESULTS_DIR} to publish)",
    )
    parser.add_argument(
        "--report-only", action="store_true", help="fly nothing: report the episodes already in --out"
    )


def run(args: argparse.Namespace) -> int:
    from agents.evaluation.leaderboard import run_leaderboard

    agents = [name.strip() for name in args.agents.split(",") if name.strip()]
    command = "flownav leaderboard " + " ".join(shlex.quote(a) for a in sys.argv[2:])
    lines = run_leaderboard(
        agents,
        Path(args.out),
        episodes=args.episodes,
        workers=args.workers,
        policies_dir=Path(args.policies_dir),
        report_only=args.report_only,
        command=command.strip(),
    )
    print("\n".join(lines))
    return 0
