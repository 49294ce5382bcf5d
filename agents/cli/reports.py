"""``flownav reports``: write every machine-written report of results/ again from the committed episodes,
flying nothing (see :mod:`agents.reports.regeneration`).

By default the reports go to a scratch folder with the layout of results/; ``--out results`` rewrites the
committed ones. ``--check`` writes them to a temporary folder and compares each with the committed file, lines
that only record when, where and with which commit a report was written left out: it prints "same" or a
unified diff per report and exits 1 if any differs. ``--list`` names every report in results/, how it is
regenerated, or why it is not.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from agents.common.locations import RESULTS_DIR, SCRATCH_DIR

HELP = "write the machine-written reports of results/ again from the committed episodes (--check: compare)"
DEFAULT_OUT = SCRATCH_DIR / "reports"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--out",
        type=Path,
        help=f"folder to write the reports into, laid out as results/ (default: {DEFAULT_OUT}; "
        f"{RESULTS_DIR} rewrites the committed reports)",
    )
    parser.add_argument(
        "--only", metavar="NAME,...", help="comma-separated reports (--list names them; default: all)"
    )
    parser.add_argument(
        "--list", action="store_true", help="list every report of results/ and how it is (or is not) made"
    )
    parser.add_argument(
        "--check",
        action="store_true",
        help="regenerate into a temporary folder and diff against the committed reports; exit 1 if any differs",
    )


def run(args: argparse.Namespace) -> int:
    # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
    from agents.reports.regeneration import listing, select_reports

    if args.list:
        print("\n".join(listing()))
        return 0
    names = [name.strip() for name in args.only.split(",") if name.strip()] if args.only else None
    select_reports(names)  # a bad name stops here, before anything is written
    if not args.check:
        _write(args.out or DEFAULT_OUT, names)
        return 0
    if args.out is not None:
        raise ValueError("--check writes to a temporary folder of its own; it takes no --out")
    return _check(names)


def _write(out: Path, names: list[str] | None) -> None:
    """Regenerate the reports into ``out``, a line per report."""
    # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
    from agents.reports.regeneration import regenerate

    for outcome in regenerate(out, names):
        if outcome.written is None:
            print(f"{outcome.report.path}: skipped, {outcome.skipped}")
        else:
            print(f"{outcome.report.path}: written to {outcome.written} ({outcome.seconds:.1f} s)")


def _check(names: list[str] | None) -> int:
    """Regenerate the reports into a temporary folder and print per report "same" or its diff; 1 if any
    differs."""
    # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
    from agents.reports.regeneration import differences, regenerate

    differ = 0
    with tempfile.TemporaryDirectory(prefix="flownav-reports-") as scratch:
        outcomes = regenerate(Path(scratch), names)
        for outcome in outcomes:
            path = outcome.report.path
            if outcome.written is None:
                print(f"{path}: skipped, {outcome.skipped}")
                continue
            diff = differences(outcome.report, outcome.written)
            differ += bool(diff)
            print(f"{path}: {'differs' if diff else 'same'} ({outcome.seconds:.1f} s)")
            if diff:
                print(diff, end="" if diff.endswith("\n") else "\n")
    compared = sum(outcome.written is not None for outcome in outcomes)
    skipped = len(outcomes) - compared
    print(f"{differ} of {compared} reports differ from the committed ones; {skipped} skipped (no data)")
    return 1 if differ else 0
