"""``flownav rule-resolution``: the flow rules (``bee_robust``, ``bee_ttc``, ``vfh``) at finer depth histograms
on suite v2's hard tiers, paired by layout against their own resolution on validation layouts; then the refinement
(the search's nearest rule at the stage's resolutions, on more, fresh layouts); each pick confirmed on fresh ones
(see :mod:`agents.studies.rule_resolution`). Flies with one worker; resumable: run it again after an
interruption, and it flies only the episodes ``--out`` lacks."""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from agents.studies.rule_resolution import STUDY

HELP = "the flow rules at finer depth histograms, chosen on validation layouts -> rule_resolution.md"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--search-layouts",
        type=int,
        default=STUDY.layouts.search,
        help="validation layouts per tier the search flies every rule at every resolution on (default: %(default)s)",
    )
    parser.add_argument(
        "--refine-layouts",
        type=int,
        default=STUDY.layouts.refinement,
        help="fresh validation layouts per tier the refinement flies its rule on at its resolutions "
        "(default: %(default)s)",
    )
    parser.add_argument(
        "--confirm-layouts",
        type=int,
        default=STUDY.layouts.confirmation,
        help="fresh validation layouts per tier a pick flies again on, with the rule's own resolution "
        "(default: %(default)s)",
    )
    parser.add_argument("--out", default="runs/rule_resolution", help="output folder (default: %(default)s)")
    parser.add_argument("--report-only", action="store_true", help="fly nothing: report what is in --out")


def run(args: argparse.Namespace) -> int:
    from agents.reports.rule_resolution_report import write_rule_resolution

    command = "flownav rule-resolution " + " ".join(shlex.quote(a) for a in sys.argv[2:])
    lines = write_rule_resolution(
        Path(args.out),
        command.strip(),
        search_layouts=args.search_layouts,
        refine_layouts=args.refine_layouts,
        confirm_layouts=args.confirm_layouts,
        report_only=args.report_only,
    )
    print("\n".join(lines))
    return 0
