"""``flownav sweep``: every agent under each sensor error at several levels, on the same held-out seeds.

See :mod:`agents.evaluation.sweep` for what a sweep flies and writes.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from agents.cli.arguments import add_layouts_argument
from agents.common.locations import CONFIGS_DIR, RESULTS_DIR, SCRATCH_DIR

HELP = "sweep agents × sensor errors (collision rates with 95 %% CIs; resumable; local or Ray)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--config",
        default=str(CONFIGS_DIR / "sweep.yaml"),
        help="the sweep's YAML (default: the repository's configs/sweep.yaml)",
    )
    parser.add_argument(
        "--out",
        default=str(SCRATCH_DIR / "sweep"),
        help="folder of sweep_episodes.csv, sweep.csv, sweep.md and the figure (default: %(default)s; "
        f"{RESULTS_DIR} to publish)",
    )
    add_layouts_argument(parser, None, "override the config's layouts per cell (default: the config's)")
    parser.add_argument(
        "--workers", type=int, help="override the config's local worker count (default: the config's)"
    )
    parser.add_argument(
        "--backend", choices=("local", "ray"), help="override the config's backend (default: the config's)"
    )
    parser.add_argument("--address", help="Ray cluster address (default: start a local Ray instance)")
    parser.add_argument(
        "--report-only",
        action="store_true",
        help="fly nothing: rebuild sweep.csv, sweep.md and the figure from the episodes flown so far",
    )
    parser.add_argument(
        "--agents",
        metavar="AGENTS",
        help="with --refly: comma-separated agents of the config whose episodes are flown again",
    )
    parser.add_argument(
        "--refly",
        nargs="?",
        const=True,
        metavar="AGENTS",
        help="delete the --agents' episodes from sweep_episodes.csv before flying, so they are flown again "
        "(after retraining a policy)",
    )
    parser.add_argument(
        "--compare-with",
        metavar="EPISODES_CSV",
        help="an earlier sweep's sweep_episodes.csv: sweep.md gets a table of each cell beside it",
    )
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="move sweep_episodes.csv to sweep_episodes.csv.bak-<time> and start a new one (nothing is deleted): "
        "for a CSV of episodes flown with other settings, or from before episode identities",
    )


def run(args: argparse.Namespace) -> int:
    # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
    from agents.evaluation.sweep import run_sweep
    from agents.pages.sweep_report import write_sweep_page

    if isinstance(args.refly, str):  # the first spelling, --refly AGENTS
        print(
            f"flownav sweep: --refly AGENTS is an old spelling; use --agents {args.refly} --refly",
            file=sys.stderr,
        )
        args.agents, args.refly = args.refly, True
    options = {
        k: v
        for k, v in vars(args).items()
        if v not in (None, False) and k not in ("handler", "command", "report_only")
    }
    command = "flownav sweep " + " ".join(
        f"--{k.replace('_', '-')}" + ("" if v is True else f" {v}") for k, v in options.items()
    )
    # Ctrl-C raises EpisodesInterrupted, which flownav prints as one line (where the episodes are), exit 130.
    flight = run_sweep(
        Path(args.config),
        Path(args.out),
        overrides={
            key: value
            for key, value in {
                "episodes": args.layouts,
                "workers": args.workers,
                "backend": args.backend,
            }.items()
            if value is not None
        },
        refly=refly_agents(args),
        compare_with=Path(args.compare_with) if args.compare_with else None,
        report_only=args.report_only,
        overwrite=args.overwrite,
        address=args.address,
    )
    write_sweep_page(flight, command)
    return 0


def refly_agents(args: argparse.Namespace) -> list[str]:
    """The agents whose sweep episodes are flown again: ``--agents`` with ``--refly``.

    Raises:
        ValueError: one given without the other.
    """
    agents = [name.strip() for name in (args.agents or "").split(",") if name.strip()]
    if args.refly and not agents:
        raise ValueError("--refly flies again the episodes of --agents AGENTS: name them")
    if agents and not args.refly:
        raise ValueError(
            "the sweep flies every agent of its config; --agents names the agents --refly flies again"
        )
    return agents
