"""Argument types shared by several ``flownav`` commands."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

import yaml

from flownav_env.settings_check import ENV_ARGUMENTS, unknown_setting_message
from flownav_env.tiers import TIERS

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


class _OldSpelling(argparse.Action):
    """An old spelling of an option: does what the current one does, and says the current name on stderr."""

    def __init__(self, option_strings: list[str], dest: str, current: argparse.Action, **_: object) -> None:
        super().__init__(
            option_strings,
            dest,
            nargs=current.nargs,
            const=current.const,
            type=current.type,  # type: ignore[arg-type]  # argparse's own action, as it was given
            choices=current.choices,
            default=argparse.SUPPRESS,
            help=argparse.SUPPRESS,
            metavar=current.metavar,
        )
        self.current = current

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: str | Sequence[str] | None,
        option_string: str | None = None,
    ) -> None:
        name = self.current.option_strings[0] if self.current.option_strings else self.current.dest
        print(f"{parser.prog}: {option_string} is an old spelling; use {name}", file=sys.stderr)
        self.current(parser, namespace, values, name)


def add_old_spellings(parser: argparse.ArgumentParser, current: argparse.Action, *old: str) -> None:
    """Accept each of ``old`` as ``current`` (an action ``parser.add_argument`` returned), hidden from the help
    and saying the current name in one line on stderr when used."""
    for spelling in old:
        parser.add_argument(spelling, action=_OldSpelling, dest=current.dest, current=current)


def add_layouts_argument(parser: argparse.ArgumentParser, default: int | None, help_text: str) -> None:
    """``--layouts N``: how many layouts (old spelling ``--episodes``)."""
    action = parser.add_argument("--layouts", type=int, default=default, help=help_text)
    add_old_spellings(parser, action, "--episodes")


def add_tier_argument(parser: argparse.ArgumentParser, default: str | None, help_text: str) -> None:
    """``--tiers TIER``, for a command that flies one tier or env: a suite tier's name or any Gymnasium id
    (old spellings ``--tier``, ``--env-id``); :func:`env_id_of` reads it."""
    action = parser.add_argument("--tiers", default=default, metavar="TIER", help=help_text)
    add_old_spellings(parser, action, "--tier", "--env-id")


def add_policies_dir_argument(parser: argparse.ArgumentParser, default: str, help_text: str) -> None:
    """``--policies-dir DIR``: where shipped policies are (old spellings ``--policy-dir``, ``--policies``)."""
    action = parser.add_argument("--policies-dir", default=default, metavar="DIR", help=help_text)
    add_old_spellings(parser, action, "--policy-dir", "--policies")


def add_seed_start_argument(parser: argparse.ArgumentParser, default: int, help_text: str) -> None:
    """``--seed-start SEED``: the first layout seed (old spelling ``--seed``)."""
    action = parser.add_argument("--seed-start", type=int, default=default, help=help_text)
    add_old_spellings(parser, action, "--seed")


def one_tier(text: str) -> str:
    """The one tier or Gymnasium id of ``--tiers`` for a command that flies one.

    Raises:
        ValueError: several given.
    """
    names = [name.strip() for name in text.split(",") if name.strip()]
    if len(names) != 1:
        raise ValueError(f"--tiers takes one tier or env id here, got {text!r}")
    return names[0]


def env_id_of(text: str) -> str:
    """The Gymnasium id ``--tiers`` names: a suite tier's own id (``hard`` → its id), else ``text`` itself (any
    registered id; Gymnasium's own error names an unknown one).

    Raises:
        ValueError: several tiers given.
    """
    name = one_tier(text)
    return TIERS[name].env_id if name in TIERS else name


def tier_name_of(text: str) -> str:
    """The current suite tier ``--tiers`` names, by its name or its Gymnasium id (``FlowNavHard-v1`` → ``hard``);
    anything else (an earlier version's id too) is returned as given, for the command's tier check to refuse in
    its words.

    Raises:
        ValueError: several tiers given.
    """
    name = one_tier(text)
    by_id = {spec.env_id: spec.name for spec in TIERS.values()}
    return by_id.get(name, name)


# About how long one episode takes a worker on the machines FlowNav is developed on (the sweep's 43,400
# episodes in 5-7 hours with two workers, README), for saying how long a flight will take before it starts.
EPISODE_SECONDS = 1.0
# A flight longer than this is announced, with how to ask for less.
NOTICE_MINUTES = 5.0


def flight_notice(command: str, episodes: int, workers: int, ask_less: str) -> str | None:
    """One line saying that ``command`` will fly up to ``episodes`` episodes and about how long that takes, with
    ``ask_less``; None for a flight of a few minutes."""
    minutes = episodes * EPISODE_SECONDS / max(workers, 1) / 60
    if minutes <= NOTICE_MINUTES:
        return None
    took = f"{minutes / 60:.1f} hours" if minutes >= 90 else f"{minutes:.0f} minutes"
    return (
        f"flownav {command}: up to {episodes:,} episodes, about {took} with {workers} worker"
        f"{'' if workers == 1 else 's'} (episodes already in the folder are not flown again); {ask_less}"
    )


def announce_flight(command: str, episodes: int, workers: int, ask_less: str) -> None:
    """Print :func:`flight_notice`'s line where there is one."""
    notice = flight_notice(command, episodes, workers, ask_less)
    if notice:
        print(notice)
