"""``flownav suite``: every agent on every tier's frozen test layouts, learned agents over all their shipped
training seeds; writes the suite's leading table (see :mod:`agents.evaluation.suite`).

Resumable: run the same command again after an interruption. Agents fly one after another in the order given,
so a partial flight reports whole agents and lists what is left.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from agents.cli.arguments import add_workers_argument, announce_flight
from agents.common.locations import RESULTS_DIR
from agents.common.seeds import SUITE_LAYOUTS
from agents.policies import suite_agents_of
from flownav_env.tiers import SUITE_VERSION, SUITE_VERSIONS, TIER_NAMES

HELP = "fly every agent on every tier's frozen test layouts; write the suite's leading table"


def add_tier_arguments(parser: argparse.ArgumentParser) -> None:
    """The options ``suite`` and ``score`` share: which tiers, how many layouts, where to fly."""

    parser.add_argument(
        "--tiers",
        default="all",
        help=f"all, or comma-separated tiers of {', '.join(TIER_NAMES)} (default: all)",
    )
    parser.add_argument(
        "--layouts",
        type=int,
        default=SUITE_LAYOUTS,
        help="the first N frozen test layouts per run (default: all %(default)s; fewer is a stated prefix)",
    )
    add_suite_version_argument(parser)
    add_workers_argument(parser)
    parser.add_argument("--backend", choices=("local", "ray"), default="local", help="where episodes fly")
    parser.add_argument("--address", help="Ray cluster address (with --backend ray; default: a local Ray)")


def add_suite_version_argument(parser: argparse.ArgumentParser) -> None:
    """``--suite-version``: which version's tiers and frozen layouts (the current one by default)."""
    parser.add_argument(
        "--suite-version",
        choices=SUITE_VERSIONS,
        default=SUITE_VERSION,
        help=f"the suite version whose tiers and frozen layouts to fly (default: {SUITE_VERSION}, the current one; "
        "1 reproduces suite v1, whose field left a capsule-free lane)",
    )


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--agents",
        help="comma-separated agents, flown in this order (default: every agent the suite version flies; "
        f"v{SUITE_VERSION}: {', '.join(suite_agents_of(SUITE_VERSION))})",
    )
    add_tier_arguments(parser)
    parser.add_argument(
        "--out", default="runs/suite", help=f"output folder (default: %(default)s; {RESULTS_DIR} to publish)"
    )
    parser.add_argument(
        "--report-only", action="store_true", help="fly nothing: report the episodes already in --out"
    )


def run(args: argparse.Namespace) -> int:
    # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
    from agents.evaluation.suite import run_suite
    from agents.pages.suite_writer import write_suite_page

    names = args.agents if args.agents is not None else ",".join(suite_agents_of(args.suite_version))
    agents = [name.strip() for name in names.split(",") if name.strip()]
    if not args.report_only:
        # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
        from agents.evaluation.suite import agent_runs, parse_tiers

        runs = sum(len(agent_runs(agent)) for agent in agents)
        announce_flight(
            "suite",
            runs * len(parse_tiers(args.tiers)) * args.layouts,
            args.workers,
            "--agents, --tiers and --layouts 30 ask for less",
        )
    command = "flownav suite " + " ".join(shlex.quote(a) for a in sys.argv[2:])
    flight = run_suite(
        agents,
        Path(args.out),
        tiers=args.tiers,
        layouts=args.layouts,
        workers=args.workers,
        backend=args.backend,
        address=args.address,
        report_only=args.report_only,
        version=args.suite_version,
    )
    lines = write_suite_page(flight, command.strip())
    print("\n".join(lines))
    return 0
