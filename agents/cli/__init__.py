"""The ``flownav`` command line: one entry point, a subcommand per job.

Each subcommand is a thin module of :mod:`agents.cli` exposing ``HELP`` (one line), ``add_arguments(parser)``
and ``run(args) -> int``: it parses, calls the package that does the work, and prints. The work is imported
inside ``run``, so that ``flownav --help`` stays instant.
"""

from __future__ import annotations

import argparse
import difflib
import importlib
import importlib.util
import sys
from collections.abc import Sequence

from agents import __version__
from agents.cli.help_text import ParagraphHelpFormatter, plain_text

COMMANDS = {
    "demo": "agents.cli.demo",
    "eval-estimator": "agents.cli.eval_estimator",
    "bench": "agents.cli.bench",
    "train": "agents.cli.train",
    "select": "agents.cli.select",
    "curves": "agents.cli.curves",
    "evaluate": "agents.cli.evaluate",
    "sweep": "agents.cli.sweep",
    "leaderboard": "agents.cli.leaderboard",
    "calibrate-tiers": "agents.cli.calibrate_tiers",
    "suite": "agents.cli.suite",
    "score": "agents.cli.score",
    "verify": "agents.cli.verify",
    "reflight": "agents.cli.reflight",
    "decision-log": "agents.cli.decision_log",
    "describe": "agents.cli.describe",
    "confirm": "agents.cli.confirm",
    "error-analysis": "agents.cli.error_analysis",
    "ablation": "agents.cli.ablation",
    "rule-resolution": "agents.cli.rule_resolution",
    "camera-reference": "agents.cli.camera_reference",
    "tune": "agents.cli.tune",
    "video": "agents.cli.video",
    "replicate": "agents.cli.replicate",
    "reports": "agents.cli.reports",
}

# Where a new user starts: the one leading table, and the path of an agent of their own.
LEADING_TABLE_EPILOG = (
    "The leading table is results/suite.md (flownav suite): every agent on every tier's frozen test layouts; "
    "results/leaderboard.md is the clean tier's history, on other layouts. Your own agent: flownav describe "
    "(what it is given and returns), flownav score --agent my_agent.py:make_agent, then flownav leaderboard "
    "--include runs/score/score.csv."
)


def build_parser() -> argparse.ArgumentParser:
    """The ``flownav`` parser: one subcommand per module of :data:`COMMANDS`.

    Returns:
        The parser; each subcommand's parsed arguments carry its ``run`` as ``handler``.
    """
    parser = argparse.ArgumentParser(
        prog="flownav", description=plain_text(__doc__.splitlines()[0]), epilog=LEADING_TABLE_EPILOG
    )
    parser.add_argument("--version", action="version", version=f"flownav {__version__}")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, module_name in COMMANDS.items():
        # Every command module ships with FlowNav: one that does not import is a broken install, said as it is.
        module = importlib.import_module(module_name)
        # The docstrings are reStructuredText for the API docs; a terminal gets them as plain paragraphs.
        sub = commands.add_parser(
            name,
            help=plain_text(module.HELP),
            description=module.__doc__ and plain_text(module.__doc__),
            formatter_class=ParagraphHelpFormatter,
        )
        module.add_arguments(sub)
        sub.set_defaults(handler=module.run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    words = list(sys.argv[1:] if argv is None else argv)
    if words and not words[0].startswith("-") and words[0] not in COMMANDS:
        # argparse lists every command; the one meant, where it is close, is what a typo needs.
        print(f"flownav: error: {unknown_command_message(words[0])}", file=sys.stderr)
        return 2
    parser = build_parser()
    args = parser.parse_args(words)
    try:
        return int(args.handler(args) or 0)
    except (ValueError, FileNotFoundError, IsADirectoryError) as error:
        # Bad input is the user's to fix: one clear line, not a traceback.
        print(f"flownav {args.command}: error: {error}", file=sys.stderr)
        return 2
    except OSError as error:
        # A full disk, a file-size limit, a read-only folder: the machine's to fix, said in one line. What
        # was written before stays (every writer appends or replaces atomically).
        print(f"flownav {args.command}: error: {describe_os_error(error)}", file=sys.stderr)
        return 1
    except KeyboardInterrupt as interrupt:
        # What was finished is on disk; the exception says where, when the command knows.
        print(
            f"flownav {args.command}: interrupted{f': {interrupt}' if str(interrupt) else ''}",
            file=sys.stderr,
        )
        return 130
    except Exception as error:
        if not _is_gymnasium_error(error):
            raise
        # Imported on this error path only: importing agents.cli loads no env until a subcommand needs one.
        from flownav_env import ENV_IDS

        print(
            f"flownav {args.command}: error: {error} (FlowNav's env ids: {', '.join(ENV_IDS)})",
            file=sys.stderr,
        )
        return 2


def unknown_command_message(word: str) -> str:
    """``unknown command 'evalute' (did you mean 'evaluate'?); commands: ...``."""
    close = difflib.get_close_matches(word, COMMANDS, n=1)
    hint = f" (did you mean {close[0]!r}?)" if close else ""
    return f"unknown command {word!r}{hint}; commands: {', '.join(COMMANDS)}"


def describe_os_error(error: OSError) -> str:
    """``error`` as one line naming the file: ``cannot write runs/x.csv: No space left on device``."""
    reason = error.strerror or str(error) or type(error).__name__
    if error.filename is None:
        return reason
    target = f"{error.filename}" + (f" -> {error.filename2}" if error.filename2 else "")
    return f"{reason}: {target}"


def _is_gymnasium_error(error: Exception) -> bool:
    """Gymnasium's own errors (an unknown env id, a bad version) are about the user's input, not a bug here."""
    return type(error).__module__.startswith("gymnasium.error")


if __name__ == "__main__":
    sys.exit(main())
