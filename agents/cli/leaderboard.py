"""``flownav leaderboard``: every agent on the same clean test layouts, learned agents over all their shipped
training seeds; writes the clean tier's 300-layout history table (see :mod:`agents.evaluation.leaderboard`). The
leading table is the suite's, ``results/suite.md`` (``flownav suite``): its layouts are others (seeds
from the suite's own frozen range in ``agents/common/seeds.py``, ``SUITE_SEED_STARTS``, against this table's from
1,000,000), so the two give the clean tier different rates.

With ``--include score.csv`` (repeatable) it flies nothing: it sets the rows ``flownav score`` wrote beside the
published suite table (``results/suite.csv``) and ranks them as ``suite.md`` ranks (privileged references
apart; each ranked agent's difference from the best, its Holm-corrected p-value, whether it joins the tier's top
group), on the layouts every included row flew, and writes ``suite_with_included.md``, ``.csv`` and ``.png``
into ``--out``. A file named twice counts once. Refused, in one line: rows of another suite version, a
published agent's name, rates outside [0, 1] or outside their interval or not summing to 1, layouts outside the
frozen set, two rows of one agent and tier, privileged data not marked privileged. Each included file is marked
verified (``flownav verify`` re-flew a sample of its episodes) or self-reported.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from agents.cli.arguments import (
    add_layouts_argument,
    add_policies_dir_argument,
    add_workers_argument,
    announce_flight,
)
from agents.cli.suite import add_suite_version_argument
from agents.common.folders import check_writable_folder, write_text_atomically
from agents.common.locations import POLICIES_DIR, RESULTS_DIR
from agents.evaluation.leaderboard import MIN_EPISODES, run_leaderboard
from agents.policies import HISTORY_AGENTS

HELP = (
    "fly every agent on the clean tier's 300 history layouts (not the leading table: that is flownav suite's); "
    "--include sets your score.csv beside the leading table"
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--agents",
        default=",".join(HISTORY_AGENTS),
        help=f"comma-separated agents (default: all, {', '.join(HISTORY_AGENTS)})",
    )
    add_layouts_argument(parser, MIN_EPISODES, "test layouts per run (default: %(default)s)")
    add_workers_argument(parser)
    add_policies_dir_argument(
        parser, str(POLICIES_DIR), "where the seeds' policies are (default: %(default)s)"
    )
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
        help="the published suite table --include adds to (default: results/suite.csv for the current version, "
        "results/suite_v1/suite.csv for --suite-version 1)",
    )
    parser.add_argument(
        "--verify",
        action="store_true",
        help="with --include: fly again, here and now, a sample of each included file's episodes with the agent "
        "its score_runs.json names (as flownav verify does), and mark the rows verified only where they match",
    )
    add_suite_version_argument(parser)


def run(args: argparse.Namespace) -> int:
    if args.include:
        return _include(args)
    if args.verify:
        raise ValueError("--verify goes with --include score.csv: it re-flies the included files' episodes")

    agents = [name.strip() for name in args.agents.split(",") if name.strip()]
    if not args.report_only:
        # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
        from agents.policies import is_learned, shipped_seed_runs

        # Each learned agent flies every shipped training seed on every layout (run_leaderboard says which).
        runs = sum(len(shipped_seed_runs(a, Path(args.policies_dir))) if is_learned(a) else 1 for a in agents)
        announce_flight(
            "leaderboard",
            runs * args.layouts,
            args.workers,
            "--agents bee,vfh flies some agents, --include runs/score/score.csv sets your rows beside the "
            "leading table without flying",
        )
    # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
    from agents.pages.leaderboard_page import write_leaderboard_page

    command = "flownav leaderboard " + " ".join(shlex.quote(a) for a in sys.argv[2:])
    board = run_leaderboard(
        agents,
        Path(args.out),
        episodes=args.layouts,
        workers=args.workers,
        policies_dir=Path(args.policies_dir),
        report_only=args.report_only,
    )
    lines = write_leaderboard_page(board, command.strip())
    print("\n".join(lines))
    return 0


def _verify_included(paths: list[str]) -> dict[Path, str] | None:
    """Each included file re-flown here (:func:`agents.evaluation.verify.verify`), as its mark; None, with the
    mismatch printed, where one does not match."""
    # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
    from agents.evaluation.included import agent_to_verify
    from agents.evaluation.verify import verify

    marks = {}
    for path in dict.fromkeys(Path(name) for name in paths):
        result = verify(path, agent_to_verify(path))
        print(f"{path}: {result.line()}")
        if result.mismatch:
            return None
        marks[path] = f"verified (re-flown in this command: {result.checked} episodes)"
    return marks


def _include(args: argparse.Namespace) -> int:
    # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
    from agents.evaluation.included import included_suite
    from agents.evaluation.suite import published_suite_csv, write_summary_csv
    from agents.pages.included_page import included_page
    from agents.pages.suite_plot import plot_suite

    version = args.suite_version
    suite_path = Path(args.suite) if args.suite else published_suite_csv(version)
    out = Path(args.out)
    check_writable_folder(out)
    command = "flownav leaderboard " + " ".join(shlex.quote(a) for a in sys.argv[2:])
    verified_now = _verify_included(args.include) if args.verify else {}
    if verified_now is None:
        return 1
    included = included_suite(suite_path, args.include, version=version, verified_now=verified_now)
    text, rows, rankings = included_page(included, command.strip()), included.table, included.rankings
    out.mkdir(parents=True, exist_ok=True)
    write_text_atomically(out / "suite_with_included.md", text)
    write_summary_csv(
        out / "suite_with_included.csv", [{k: v for k, v in r.items() if k != "included"} for r in rows]
    )
    plot_suite(rows, out / "suite_with_included.png", {name: r.top_group for name, r in rankings.items()})
    print(text)
    print(f"written to {out / 'suite_with_included.md'}")
    return 0
