"""The main job in a few minutes: every agent of the suite (the reactive rules, every shipped learned agent over
all its training seeds, the privileged planner as a reference) on the first few of a tier's frozen test layouts,
ranked as ``results/suite.md`` ranks them (:mod:`agents.evaluation.suite`): the same table, written to
``runs/demo/`` (``suite.md``, ``suite.csv``, ``suite.png``; resumable). A few layouts cannot tell most agents
apart, so the page says on how many it rests; the leading table is ``results/suite.md``, every tier's 300
frozen test layouts (``flownav suite``)."""

from __future__ import annotations

import argparse
from pathlib import Path

from agents.cli.arguments import add_layouts_argument, add_tier_argument, add_workers_argument, tier_name_of
from agents.common.locations import RESULTS_DIR
from agents.common.seeds import SUITE_LAYOUTS
from flownav_env.tiers import TIER_NAMES

HELP = "every agent of the suite on a few of a tier's frozen test layouts, ranked as suite.md (the README's main job)"

DEMO_LAYOUTS = 4


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_layouts_argument(
        parser,
        DEMO_LAYOUTS,
        f"the first N of the tier's {SUITE_LAYOUTS} frozen test layouts (default: %(default)s)",
    )
    add_tier_argument(parser, TIER_NAMES[0], f"one of {', '.join(TIER_NAMES)} (default: %(default)s)")
    parser.add_argument("--out", default="runs/demo", help="output folder (default: %(default)s)")
    add_workers_argument(parser)


def run(args: argparse.Namespace) -> int:
    # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
    from agents.evaluation.suite import run_suite, suite_agents
    from agents.pages.suite_writer import write_suite_page

    if not 2 <= args.layouts <= SUITE_LAYOUTS:
        raise ValueError(
            f"--layouts must be 2-{SUITE_LAYOUTS} (a ranking compares agents on at least 2), got {args.layouts}"
        )
    tier_name = tier_name_of(args.tiers)
    out = Path(args.out)
    flight = run_suite(suite_agents(), out, tiers=tier_name, layouts=args.layouts, workers=args.workers)
    lines = write_suite_page(flight, f"flownav demo --layouts {args.layouts} --tiers {tier_name} --out {out}")
    print("\n".join(lines))
    print(demo_note(args.layouts, tier_name, out))
    return 0


def demo_note(layouts: int, tier_name: str, out: Path) -> str:
    """What the demo's table rests on, where it is written, and where the leading table is."""
    plural = "" if layouts == 1 else "s"
    return (
        f"\nThe demo: every agent on the first {layouts} frozen test layout{plural} of the {tier_name} tier, ranked "
        f"as the suite ranks; written to {out / 'suite.md'} (and suite.csv, suite.png). {layouts} layout{plural} "
        f"tell few agents apart: the leading table, every tier's {SUITE_LAYOUTS} layouts, is "
        f"{RESULTS_DIR / 'suite.md'} (flownav suite)."
    )
