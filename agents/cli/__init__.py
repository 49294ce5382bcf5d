"""The ``flownav`` command line: one entry point, a subcommand per job.

Each subcommand is a thin module of :mod:`agents.cli` exposing ``HELP`` (one line), ``add_arguments(parser)``
and ``run(args) -> int``: it parses, calls the package that does the work, and prints. The work is imported
inside ``run``, so that ``flownav --help`` stays instant.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import sys
from collections.abc import Sequence

COMMANDS = {
    "demo": "agents.cli.demo",
    "eval-estimator": "agents.cli.eval_estimator",
    "bench": "agents.cli.bench",
    "train": "agents.cli.train",
    "curves": "agents.cli.curves",
    "evaluate": "agents.cli.evaluate",
    "sweep": "agents.cli.sweep",
    "tune-bee": "agents.cli.tune_bee",
    "video": "agents.cli.video",
    "replicate": "agents.cli.replicate",
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="flownav", description=__doc__.splitlines()[0])
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, module_name in COMMANDS.items():
        if importlib.util.find_spec(module_name) is None:
            continue
        module = importlib.import_module(module_name)
        sub = commands.add_parser(name, help=module.HELP, description=module.__doc__)
        module.add_arguments(sub)
        sub.set_defaults(handler=module.run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.handler(args) or 0)
    except (ValueError, FileNotFoundError) as error:
        # Bad input is the user's to fix: one clear line, not a traceback.
        print(f"flownav {args.command}: error: {error}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
