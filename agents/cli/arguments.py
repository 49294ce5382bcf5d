"""Argument types shared by several ``flownav`` commands."""

from __future__ import annotations

import argparse

import yaml


def env_kwarg(text: str) -> tuple[str, object]:
    """``--env KEY=VALUE``: the pair, the value read as YAML (``0.18`` a float, ``oracle`` a string)."""
    if "=" not in text:
        raise argparse.ArgumentTypeError(f"expected KEY=VALUE, got {text!r}")
    key, value = text.split("=", 1)
    return key, yaml.safe_load(value)


def add_env_argument(parser: argparse.ArgumentParser, help_text: str) -> None:
    """``--env KEY=VALUE``, repeatable, collected as a list of pairs (``dict(args.env)``)."""
    parser.add_argument(
        "--env", type=env_kwarg, action="append", default=[], metavar="KEY=VALUE", help=help_text
    )
