"""Every option a flying command's messages suggest is an option of that command."""

from __future__ import annotations

import argparse
import re

import pytest

from agents.analysis.records import FRESH_FILE_HINT, OVERWRITE_HINT, overwrite_hint, predates_identities
from agents.cli import build_parser
from agents.evaluation.sweep import SWEEP_REMEDY
from agents.policies.agent_limits import timeout_message


def options_of(command: str) -> set[str]:
    """The option strings ``flownav <command>`` accepts."""
    (commands,) = (a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return {option for action in commands.choices[command]._actions for option in action.option_strings}


def suggested(message: str) -> set[str]:
    return set(re.findall(r"--[a-z][a-z-]*", message))


@pytest.mark.parametrize(
    ("command", "messages"),
    [
        # What each command passes as its remedy when its CSV cannot be resumed, and what else it may say.
        ("evaluate", [OVERWRITE_HINT]),
        ("sweep", [SWEEP_REMEDY, predates_identities("x.csv", SWEEP_REMEDY)]),
        ("score", [overwrite_hint("folder"), timeout_message("a.py:make", "an episode", 1.0)]),
        ("suite", [FRESH_FILE_HINT]),
        ("leaderboard", [FRESH_FILE_HINT]),
    ],
)
def test_each_suggested_option_is_the_commands_own(command: str, messages: list[str]) -> None:
    wanted = set().union(*(suggested(message) for message in messages))
    assert wanted - options_of(command) == set()


def test_the_default_remedy_suggests_no_option() -> None:
    assert suggested(FRESH_FILE_HINT) == set()
    assert "--overwrite" in OVERWRITE_HINT and "--refly" in SWEEP_REMEDY
