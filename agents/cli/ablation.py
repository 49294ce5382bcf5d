"""``flownav ablation``: training configs compared over their seeds on validation layouts (the flow-gap levers),
see :mod:`agents.studies.ablation`."""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from agents.cli.arguments import (
    add_env_argument,
    add_layouts_argument,
    add_policies_dir_argument,
    add_tier_argument,
    tier_name_of,
)
from agents.cli.suite import add_suite_version_argument
from agents.common.locations import POLICIES_DIR
from agents.common.seeds import TIER_CONFIRM_SEED_STARTS

HELP = "compare training configs over their seeds on validation layouts -> ablation.md"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--configs", nargs="+", required=True, help="training config YAMLs, e.g. configs/ppo_flow.yaml"
    )
    parser.add_argument(
        "--seeds", default="0-2", help="training seeds, e.g. 0-2 or 0,3 (default: %(default)s)"
    )
    add_layouts_argument(parser, 100, "validation layouts per run (default: %(default)s)")
    parser.add_argument(
        "--workers", type=int, default=2, help="local worker processes (default: %(default)s)"
    )
    parser.add_argument(
        "--reference",
        default="",
        help="comma-separated reactive agents flown on the same layouts as reference rows, e.g. bee_robust,bee",
    )
    parser.add_argument("--runs-dir", default="runs", help="where the seeds' runs are (default: %(default)s)")
    add_policies_dir_argument(
        parser,
        str(POLICIES_DIR),
        "where a seed whose run folder is gone is read from, as shipped: <DIR>/<name>/seed_<k>.zip "
        "(default: %(default)s)",
    )
    add_env_argument(
        parser,
        "FlowNavEnv setting every run flies with, repeatable (e.g. --env obstacle_density=0.18; default: "
        "none, clean); give each condition its own --out, for its own ablation.md",
    )
    add_tier_argument(
        parser,
        None,
        "a suite tier (clean, hard, noisy, hard_noisy): fly its course and sensor on its validation layouts "
        "(suite v1 from 960,100, v2 from 972,000) instead of the ablation layouts; a recipe for every tier "
        "(per_tier: true) is read as that tier's runs, <name>_<tier>; takes no --env",
    )
    add_suite_version_argument(parser)
    parser.add_argument(
        "--confirm",
        action="store_true",
        help="with --tiers: fly the tier's fresh confirmation layouts ("
        + ", ".join(f"suite v{version} from {start:,}" for version, start in TIER_CONFIRM_SEED_STARTS.items())
        + "), on which nothing was chosen, instead of its recipe layouts: a recipe picked there flown again",
    )
    parser.add_argument(
        "--layout-start",
        type=int,
        default=None,
        help="fly the validation layouts from this seed instead (a search's own range, declared in "
        "configs/decisions.yaml before its flights; default: the tier's or the ablation's)",
    )
    parser.add_argument("--out", default="runs/ablation", help="output folder (default: %(default)s)")
    parser.add_argument("--report-only", action="store_true", help="fly nothing: report what is in --out")


def run(args: argparse.Namespace) -> int:
    # Imported on use: `flownav --help` imports every subcommand module and must stay quick.
    from agents.studies.ablation import compare_configs
    from agents.training.multiseed import parse_seeds

    if args.workers < 1:
        raise ValueError(f"--workers must be >= 1, got {args.workers}")
    command = "flownav ablation " + " ".join(shlex.quote(a) for a in sys.argv[2:])
    lines = compare_configs(
        [Path(path) for path in args.configs],
        parse_seeds(args.seeds),
        Path(args.out),
        runs_dir=Path(args.runs_dir),
        policies_dir=Path(args.policies_dir),
        episodes=args.layouts,
        workers=args.workers,
        report_only=args.report_only,
        command=command.strip(),
        reference_agents=[agent.strip() for agent in args.reference.split(",") if agent.strip()],
        env=dict(args.env),
        tier=args.tiers and tier_name_of(args.tiers),
        suite_version=args.suite_version,
        confirm=args.confirm,
        layout_start=args.layout_start,
    )
    print("\n".join(lines))
    return 0
