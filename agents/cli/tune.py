"""``flownav tune``: tune a reactive agent's parameters on training seeds only.

An optuna TPE search (every trial on the same training layouts, trial 0 the agent's defaults), then the best
trials and the defaults on fresh training layouts, where the winner is chosen. Resumable: every episode is
appended to ``<out>/episodes.csv`` as it ends, and the same command continues where it stopped. Writes
``tuning.md``, ``best.json`` and ``tuning_curve.png`` beside it.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from agents.cli.arguments import add_old_spellings, add_tier_argument, env_id_of
from agents.common.agent_table import agents_where
from agents.common.locations import SCRATCH_DIR
from flownav_env.tiers import TIER_NAMES

HELP = "tune a reactive agent on training seeds (TPE search, then finalists on fresh layouts; resumable)"

# The agents with a search_space in configs/agents.yaml, read from the table alone (no optuna, no agent class)
# so that `flownav --help` stays quick.
TUNABLE_AGENTS = agents_where(tunable=True)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--agent", required=True, choices=TUNABLE_AGENTS, help="the agent to tune")
    parser.add_argument("--trials", type=int, default=40, help="search trials (default: %(default)s)")
    search = parser.add_argument(
        "--search-layouts",
        type=int,
        default=30,
        help="training layouts every search trial flies, the same for all (default: %(default)s)",
    )
    parser.add_argument(
        "--finalists",
        type=int,
        default=4,
        help="best search trials flown again on fresh layouts, plus the defaults (default: %(default)s)",
    )
    add_old_spellings(parser, search, "--search-episodes")
    final = parser.add_argument(
        "--final-layouts",
        type=int,
        default=150,
        help="fresh training layouts per finalist, at least 100 (default: %(default)s)",
    )
    parser.add_argument(
        "--workers", type=int, default=2, help="local worker processes (default: %(default)s)"
    )
    add_old_spellings(parser, final, "--final-episodes")
    add_tier_argument(
        parser,
        "clean",
        f"a suite tier ({', '.join(TIER_NAMES)}) or any Gymnasium id such as FlowNavSingle-v0 (default: %(default)s)",
    )
    parser.add_argument(
        "--out",
        type=Path,
        help=f"output folder (default: {SCRATCH_DIR}/tuning/<agent>; results/tuning/<agent> to publish)",
    )
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="move <out>/episodes.csv to episodes.csv.bak-<time> and start a new one (nothing is deleted)",
    )


def run(args: argparse.Namespace) -> int:
    # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
    from agents.studies.tuning import Budget, tune

    budget = Budget(args.trials, args.search_layouts, args.finalists, args.final_layouts)
    result = tune(
        args.agent,
        args.out or SCRATCH_DIR / "tuning" / args.agent,
        budget,
        env_id=env_id_of(args.tiers),
        workers=args.workers,
        overwrite=args.overwrite,
    )
    print("\n".join(result.lines))
    return 0
