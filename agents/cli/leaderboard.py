"""``flownav leaderboard``: every agent on the same clean test layouts, learned agents over all their shipped
training seeds; writes the clean tier's 300-layout history table (see :mod:`agents.evaluation.leaderboard`).

With ``--include score.csv`` (repeatable) it flies nothing: it sets the rows ``flownav score`` wrote beside the
published suite table (``results/suite.csv``), tier by tier, and writes ``suite_with_included.md`` and ``.csv``
into ``--out``. Rows of another suite version are refused.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from agents.common.locations import POLICIES_DIR, RESULTS_DIR

HELP = "fly every agent (learned ones over their training seeds) on the test layouts; write the leading table"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from agents.evaluation.leaderboard import MIN_EPISODES
    from agents.policies import AGENT_NAMES

    parser.add_argument(
        "--agents",
        default=",".join(AGENT_NAMES),
        help=f"comma-separated agents (default: all, {','.join(AGENT_NAMES)})",
    )
    parser.add_argument(
        "--episodes", type=int, default=MIN_EPISODES, help="test layouts per run (default: %(default)s)"
    )
    parser.add_argument(
        "--workers", type=int, default=2, help="local worker processes (default: %(default)s)"
    )
    parser.add_argument("--policies-dir", default=str(POLICIES_DIR), help="where the seeds' policies are")
    parser.add_argument(
        "--out",
        default="runs/leaderboard",
        help=f"output folder (default runs/leaderboard; {RESULTS_DIR} to publish)",
    )
    parser.add_argument(
        "--report-only", action="store_true", help="fly nothing: report the episodes already in --out"
    )
    parser.add_argument(
        "--include",
        action="append",
        default=[],
        metavar="CSV",
        help="a score.csv from flownav score to set beside the published suite table (repeatable; flies nothing)",
    )
    parser.add_argument(
        "--suite",
        default=str(RESULTS_DIR / "suite.csv"),
        help="the published suite table --include adds to (default: %(default)s)",
    )


def run(args: argparse.Namespace) -> int:
    if args.include:
        return _include(args)
    from agents.evaluation.leaderboard import run_leaderboard

    agents = [name.strip() for name in args.agents.split(",") if name.strip()]
    command = "flownav leaderboard " + " ".join(shlex.quote(a) for a in sys.argv[2:])
    lines = run_leaderboard(
        agents,
        Path(args.out),
        episodes=args.episodes,
        workers=args.workers,
        policies_dir=Path(args.policies_dir),
        report_only=args.report_only,
        command=command.strip(),
    )
    print("\n".join(lines))
    return 0


def _include(args: argparse.Namespace) -> int:
    from agents.common.folders import check_writable_folder, write_text_atomically
    from agents.evaluation.suite import write_summary_csv
    from agents.evaluation.suite_report import merge_rows, plot_suite, read_suite_csv, tier_tables

    published = read_suite_csv(Path(args.suite))
    included = [row for path in args.include for row in read_suite_csv(Path(path))]
    rows = merge_rows(published, included)
    out = Path(args.out)
    check_writable_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    lines = [
        f"# The suite table with {len(included)} included rows",
        "",
        f"Published rows from `{args.suite}`; included rows from {', '.join(f'`{p}`' for p in args.include)}.",
        "",
        *tier_tables(rows),
    ]
    write_text_atomically(out / "suite_with_included.md", "\n".join(lines) + "\n")
    write_summary_csv(
        out / "suite_with_included.csv", [{k: v for k, v in r.items() if k != "included"} for r in rows]
    )
    plot_suite(rows, out / "suite_with_included.png")
    print("\n".join(lines))
    print(f"written to {out / 'suite_with_included.md'}")
    return 0
