"""``flownav decision-log``: the choices behind the suite's test flights (``configs/decisions.yaml``) beside what
the repository's history says of each: the test rows already committed when it was made, and whether the flights
it governs were flown by code that descends from it. Writes ``decision_log.md`` into ``--out``; needs a git
checkout with its history.
"""

from __future__ import annotations

import argparse
from pathlib import Path

HELP = (
    "the choices behind the suite's test flights, beside the test rows visible when each was made (from git)"
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--out", default="runs/decision_log", help="output folder (default: %(default)s; results to publish)"
    )


def run(args: argparse.Namespace) -> int:
    # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
    from agents.studies.decision_log import write_decision_log

    path = write_decision_log(Path(args.out), f"flownav decision-log --out {args.out}")
    print(f"written to {path}")
    return 0
