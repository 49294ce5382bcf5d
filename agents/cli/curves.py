"""Compares training runs: the held-out evaluation return of each run against environment steps, in one
figure (``flownav curves runs/ppo_flow/evaluations.npz ... --out results/learning_curves.png``).
Each input is the ``evaluations.npz`` an SB3 ``EvalCallback`` writes (``runs/<name>/evaluations.npz``, copied
to ``results/policies/<name>_evaluations.npz``); a run is labelled by its file name."""

from __future__ import annotations

import argparse
from pathlib import Path

from agents.common.locations import SCRATCH_DIR

HELP = "plot the held-out evaluation return of training runs against steps, one line per run"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("evaluations", nargs="+", help="evaluations.npz files, one per run")
    parser.add_argument(
        "--out",
        default=str(SCRATCH_DIR / "learning_curves.png"),
        help="the figure (default: %(default)s; a path in results/ to publish)",
    )
    parser.add_argument("--title", default="held-out evaluation")


def run(args: argparse.Namespace) -> int:
    paths = [Path(p) for p in args.evaluations]
    for path in paths:
        if not path.is_file():
            raise FileNotFoundError(f"evaluations file not found: {path}")
    # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
    from agents.training.curves import plot_learning_curves, run_label

    curves = {run_label(path): path for path in paths}
    if len(curves) != len(paths):
        raise ValueError(f"two evaluations files give the same run name: {[str(p) for p in paths]}")
    plot_learning_curves(curves, Path(args.out), args.title)
    print(f"wrote {args.out}")
    return 0
