"""``flownav confirm``: the lever search's pick against its first stage and ``ppo_flow`` on fresh validation
layouts, every training seed on every layout, clean and under the two robustness conditions (see
:mod:`agents.studies.confirmation`). Resumable: run it again after an interruption."""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from agents.studies.confirmation import CONFIRMATION_LAYOUTS, write_confirmation

HELP = "confirm the lever search's pick on fresh validation layouts, paired by layout -> confirmation.md"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--layouts",
        type=int,
        default=CONFIRMATION_LAYOUTS,
        help="fresh validation layouts (default: %(default)s)",
    )
    parser.add_argument(
        "--workers", type=int, default=2, help="local worker processes (default: %(default)s)"
    )
    parser.add_argument("--out", default="runs/confirmation", help="output folder (default: %(default)s)")
    parser.add_argument("--report-only", action="store_true", help="fly nothing: report what is in --out")


def run(args: argparse.Namespace) -> int:
    command = "flownav confirm " + " ".join(shlex.quote(a) for a in sys.argv[2:])
    flights = {"layouts": args.layouts, "workers": args.workers, "report_only": args.report_only}
    print("\n".join(write_confirmation(Path(args.out), command.strip(), **flights)))
    return 0
