"""``flownav calibrate-tiers``: fly the suite's candidate hard courses and every frozen tier on validation
layouts, and write how each tier was chosen (see :mod:`agents.studies.tier_calibration`)."""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from agents.studies.tier_calibration import STUDY, write_calibration

HELP = "choose the suite's hard course on validation layouts and check every tier -> calibration.md"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--layouts",
        type=int,
        default=STUDY.layouts,
        help="validation layouts per candidate and tier (default: %(default)s)",
    )
    parser.add_argument(
        "--workers", type=int, default=2, help="local worker processes (default: %(default)s)"
    )
    parser.add_argument(
        "--out", default="runs/suite_calibration", help="output folder (default: %(default)s)"
    )
    parser.add_argument(
        "--stage",
        choices=("course", "tiers", "both"),
        default="both",
        help="fly the candidate courses, the frozen tiers, or both (default: %(default)s)",
    )
    parser.add_argument("--report-only", action="store_true", help="fly nothing: report what is in --out")


def run(args: argparse.Namespace) -> int:
    if args.layouts < 1:
        raise ValueError(f"--layouts must be >= 1, got {args.layouts}")
    if args.workers < 1:
        raise ValueError(f"--workers must be >= 1, got {args.workers}")
    command = "flownav calibrate-tiers " + " ".join(shlex.quote(a) for a in sys.argv[2:])
    stages = ("course", "tiers") if args.stage == "both" else (args.stage,)
    flights = {
        "layouts": args.layouts,
        "workers": args.workers,
        "report_only": args.report_only,
        "stages": stages,
    }
    print("\n".join(write_calibration(Path(args.out), command.strip(), **flights)))
    return 0
