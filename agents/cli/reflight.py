"""``flownav reflight``: fly a sample of published suite episodes again here and record which re-fly bit for bit.

Each agent's sample (``--episodes`` per tier, drawn with ``--seed``) is flown with this checkout's code on this
machine's CPU and compared with its published row; ``<out>/suite_reflight.csv`` keeps every CPU's results (a
re-flight of the same episode on the same CPU replaces the old), and ``suite.md`` says from it what re-flies
bit for bit and where. Run it on another machine and commit the file to add that CPU.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from agents.cli.arguments import announce_flight

HELP = "fly a sample of published suite episodes again here: which re-fly bit for bit, on which CPU"
DEFAULT_AGENTS = "bee_ttc,ppo_flow_camera_student_fine_rounds6"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--agents", default=DEFAULT_AGENTS, help="comma-separated suite agents (default: %(default)s)"
    )
    parser.add_argument("--tiers", default="hard", help="comma-separated tiers (default: %(default)s)")
    parser.add_argument(
        "--episodes", type=int, default=10, help="episodes per agent and tier (default: %(default)s)"
    )
    parser.add_argument("--seed", type=int, default=0, help="the draw of the episodes (default: %(default)s)")
    parser.add_argument(
        "--out", default="runs/reflight", help="output folder (default: %(default)s; results to publish)"
    )


def run(args: argparse.Namespace) -> int:
    # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
    from agents.analysis.reflights import REFLIGHT_CSV, summarise_reflights, write_reflights
    from agents.common.locations import RESULTS_DIR
    from agents.evaluation.reflight import pick_episodes, reflight
    from agents.evaluation.suite import EPISODES_CSV, parse_tiers

    if args.episodes < 1:
        raise ValueError(f"--episodes must be >= 1, got {args.episodes}")
    agents = [name.strip() for name in args.agents.split(",") if name.strip()]
    tiers = parse_tiers(args.tiers)
    picked = {
        agent: pick_episodes(agent, tiers, args.episodes, RESULTS_DIR / EPISODES_CSV, args.seed)
        for agent in agents
    }
    announce_flight(
        "reflight", sum(len(chosen) for chosen in picked.values()), 1, "--episodes 3 is a quick look"
    )
    rows = [row for agent, chosen in picked.items() for row in reflight(chosen, agent)]
    path = Path(args.out) / REFLIGHT_CSV
    write_reflights(path, rows)
    for summary in summarise_reflights(rows):
        print(
            f"{summary.agent} on {summary.cpu}: {summary.identical} of {summary.flown} identical, "
            f"{summary.same_outcome} of {summary.flown} with the same outcome"
            + (f" (differed: {summary.differed})" if summary.differed else "")
        )
    print(f"written to {path}")
    return 0
