"""``flownav replicate``: the thesis's estimator experiments replayed in FlowNav (see :mod:`agents.studies.thesis`)."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from agents.common.locations import CONFIGS_DIR, RESULTS_DIR

HELP = "reproduce the thesis's estimator experiments (record/playback, Tables 2-3, test-sets C-H)"

DEFAULT_CONFIGS = CONFIGS_DIR / "thesis"
# Runs land in a scratch folder unless asked: the committed results/thesis/ is replaced only on purpose.
DEFAULT_OUT = Path("runs") / "thesis"
# Kept in step with agents.studies.thesis.experiments.EXPERIMENTS (a test checks); listed here so --help stays instant.
EXPERIMENT_NAMES = ("straight", "rotation", "translation", "random6dof", "three_capsule")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register ``--only``, ``--configs``, ``--out`` and ``--no-progress``."""
    parser.add_argument(
        "--only", choices=EXPERIMENT_NAMES, action="append", help="run only this experiment (repeatable)"
    )
    parser.add_argument(
        "--configs", type=Path, default=DEFAULT_CONFIGS, help="folder of the <name>.yaml configs"
    )
    parser.add_argument(
        "--out",
        type=Path,
        default=DEFAULT_OUT,
        help=f"output folder of the figures, JSON and README.md (default {DEFAULT_OUT}, a scratch folder; "
        f"--out {RESULTS_DIR / 'thesis'} replaces the committed results)",
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bars")


def run(args: argparse.Namespace) -> int:
    """Run the selected experiments, then rewrite the README from all results in ``--out``."""
    # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
    from agents.studies.thesis.report import run_experiment, write_readme

    names = args.only or list(EXPERIMENT_NAMES)
    started = time.perf_counter()
    for name in names:
        result = run_experiment(name, args.configs / f"{name}.yaml", args.out, progress=not args.no_progress)
        print(f"{name}: {result['wall_s']:.1f} s")
    total = time.perf_counter() - started
    write_readme(args.out, names, total)
    print(f"wrote {args.out / 'README.md'} ({total:.1f} s)")
    return 0
