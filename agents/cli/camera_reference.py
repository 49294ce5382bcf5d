"""``flownav camera-reference``: the camera-limited planners (``planner_camera``, ``planner_camera_observed``)
beside ``planner``, which knows the whole map, on the closed field (capsules across the whole lateral bound), on
the clean course and the hard one, 20 validation layouts each; one process per agent and course, its CPU and wall
seconds recorded beside its episodes, then ``summary.csv`` (see :mod:`agents.studies.camera_reference`). Writes
to ``--out``: by default ``{scratch_out}``, a scratch folder; ``--out results/camera_reference`` replaces the
committed check."""

from __future__ import annotations

import argparse
from pathlib import Path

# Runs land in a scratch folder unless asked: the committed check in results/ is replaced only on purpose.
SCRATCH_OUT = Path("runs") / "camera_reference"
if __doc__:  # None under python -OO
    __doc__ = __doc__.replace("{scratch_out}", SCRATCH_OUT.as_posix())

HELP = "the camera-limited planners beside planner on the closed field (validation layouts) -> summary.csv"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--out",
        type=Path,
        default=SCRATCH_OUT,
        help=f"output folder (default {SCRATCH_OUT}, a scratch folder; --out results/camera_reference replaces "
        "the committed check)",
    )
    parser.add_argument(
        "--summary-only", action="store_true", help="fly nothing: summarise the episodes and times in --out"
    )


def run(args: argparse.Namespace) -> int:
    # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
    from agents.studies.camera_reference import fly_camera_reference, write_summary

    paths = [] if args.summary_only else fly_camera_reference(args.out)
    for path in [*paths, write_summary(args.out)]:
        print(f"wrote {path}")
    return 0
