"""Argument types shared by several ``flownav`` commands."""

from __future__ import annotations

import argparse

import yaml

from flownav_env.settings_check import ENV_ARGUMENTS, unknown_setting_message

# Every command that flies episodes in local processes starts from this many unless told (--workers): two, as
# the machines FlowNav is developed and benchmarked on have two cores (`nproc` in results/training_performance.md).
DEFAULT_WORKERS = 2


def env_kwarg(text: str) -> tuple[str, object]:
    """``--env KEY=VALUE``: the pair, the value read as YAML (``0.18`` a float, ``oracle`` a string).

    Raises:
        argparse.ArgumentTypeError: no ``=``, or a key that is no env argument (with the nearest one, as the
            env itself says it).
    """

    if "=" not in text:
        raise argparse.ArgumentTypeError(f"expected KEY=VALUE, got {text!r}")
    key, value = text.split("=", 1)
    if key not in ENV_ARGUMENTS:
        raise argparse.ArgumentTypeError(unknown_setting_message(key, ENV_ARGUMENTS))
    return key, yaml.safe_load(value)


def add_env_argument(parser: argparse.ArgumentParser, help_text: str) -> None:
    """``--env KEY=VALUE``, repeatable, collected as a list of pairs (``dict(args.env)``)."""
    parser.add_argument(
        "--env", type=env_kwarg, action="append", default=[], metavar="KEY=VALUE", help=help_text
    )


def add_workers_argument(parser: argparse.ArgumentParser) -> None:
    """``--workers N``: local worker processes, by default :data:`DEFAULT_WORKERS`."""
    parser.add_argument(
        "--workers",
        type=int,
        default=DEFAULT_WORKERS,
        help="local worker processes (default: %(default)s)",
    )
