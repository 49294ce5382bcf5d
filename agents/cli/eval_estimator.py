"""Runs the flow depth estimator on every frame pair (i, j) with 0 < j - i <= --max-gap of an ICL-NUIM-style
RGB-D sequence (color/, depth/ PNGs in millimetres, trajectory.log) and prints the error table against the
ground-truth depth."""

from __future__ import annotations

import argparse
from pathlib import Path

from estimator import CameraIntrinsics
from estimator.accuracy import evaluate_sequence, format_error_table

HELP = "depth error of the estimator on a real RGB-D sequence (trajectory.log + depth PNGs)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--sequence", required=True, help="folder with color/, depth/ and trajectory.log")
    parser.add_argument("--method", choices=("triangulation", "thesis"), default="triangulation")
    parser.add_argument("--max-gap", type=int, default=4, help="largest frame gap of a pair (default 4)")
    parser.add_argument("--fx", type=float, default=525.0, help="focal length along x, px (ICL-NUIM: 525)")
    parser.add_argument("--fy", type=float, default=525.0)
    parser.add_argument("--cx", type=float, default=319.5)
    parser.add_argument("--cy", type=float, default=239.5)
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=480)


def run(args: argparse.Namespace) -> int:
    intrinsics = CameraIntrinsics(
        fx=args.fx, fy=args.fy, cx=args.cx, cy=args.cy, width=args.width, height=args.height
    )
    rows = evaluate_sequence(Path(args.sequence), intrinsics, method=args.method, max_gap=args.max_gap)
    print(format_error_table(rows))
    return 0
