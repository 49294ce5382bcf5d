"""The ``flownav`` command line: one entry point, a subcommand per job.

Each subcommand's work lives in its own module; this file only parses arguments and dispatches, importing
heavy modules lazily so ``flownav --help`` stays instant.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path


def _eval_estimator(args: argparse.Namespace) -> int:
    from estimator import CameraIntrinsics
    from estimator.evaluation import evaluate_sequence, format_error_table

    intrinsics = CameraIntrinsics(
        fx=args.fx, fy=args.fy, cx=args.cx, cy=args.cy, width=args.width, height=args.height
    )
    rows = evaluate_sequence(Path(args.sequence), intrinsics, method=args.method, max_gap=args.max_gap)
    print(format_error_table(rows))
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="flownav", description=__doc__.splitlines()[0])
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    ev = commands.add_parser(
        "eval-estimator",
        help="depth error of the estimator on a real RGB-D sequence (trajectory.log + depth PNGs)",
        description="Runs the flow depth estimator on every frame pair (i, j) with 0 < j - i <= --max-gap of an "
        "ICL-NUIM-style sequence and prints the error table against the ground-truth depth.",
    )
    ev.add_argument("--sequence", required=True, help="folder with color/, depth/ and trajectory.log")
    ev.add_argument("--method", choices=("triangulation", "thesis"), default="triangulation")
    ev.add_argument("--max-gap", type=int, default=4, help="largest frame gap of a pair (default 4)")
    ev.add_argument("--fx", type=float, default=525.0)
    ev.add_argument("--fy", type=float, default=525.0)
    ev.add_argument("--cx", type=float, default=319.5)
    ev.add_argument("--cy", type=float, default=239.5)
    ev.add_argument("--width", type=int, default=640)
    ev.add_argument("--height", type=int, default=480)
    ev.set_defaults(handler=_eval_estimator)
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
