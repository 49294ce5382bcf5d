"""Options shared by several commands: ``--env`` keys checked with the env's own suggestion, one ``--workers``
default, one name for the policies folder, and help that never cuts an agent name (the rest of the flag
vocabulary: ``test_vocabulary.py``)."""

from __future__ import annotations

import argparse

import pytest

from agents.cli import build_parser, main
from agents.cli.arguments import DEFAULT_WORKERS, env_kwarg
from agents.policies import HISTORY_AGENTS, suite_agents_of
from flownav_env.tiers import SUITE_VERSION


@pytest.mark.parametrize(
    "command", [["evaluate", "--agent", "straight"], ["ablation", "--configs", "c.yaml"]]
)
def test_an_env_key_typo_says_which_key_was_meant_and_exits_2(
    command: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as stopped:
        main([*command, "--env", "rotation_eror=0.1"])
    assert stopped.value.code == 2
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert error.startswith(f"flownav {command[0]}: error: argument --env: unknown setting 'rotation_eror'")
    assert error.endswith("(did you mean 'rotation_error'?)")


def test_env_pairs_are_read_as_yaml() -> None:
    assert env_kwarg("obstacle_density=0.18") == ("obstacle_density", 0.18)
    with pytest.raises(argparse.ArgumentTypeError, match="expected KEY=VALUE, got 'obstacle_density'"):
        env_kwarg("obstacle_density")


def test_every_flying_command_shares_one_workers_default() -> None:
    commands = build_parser()._subparsers._group_actions[0].choices
    for name in ("demo", "leaderboard", "suite", "score"):
        (workers,) = [action for action in commands[name]._actions if action.dest == "workers"]
        assert workers.default == DEFAULT_WORKERS, name


def test_the_policies_folder_has_one_name_and_its_old_ones_still_work(
    capsys: pytest.CaptureFixture[str],
) -> None:
    parser = build_parser()
    assert parser.parse_args(["leaderboard", "--policies-dir", "/tmp/p"]).policies_dir == "/tmp/p"
    for option in ("--policy-dir", "--policies"):
        assert (
            parser.parse_args(["ablation", "--configs", "c.yaml", option, "/tmp/p"]).policies_dir == "/tmp/p"
        )
        assert f"{option} is an old spelling; use --policies-dir" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("command", "names"), [("leaderboard", HISTORY_AGENTS), ("suite", suite_agents_of(SUITE_VERSION))]
)
def test_help_never_cuts_an_agent_name(
    command: str, names: tuple[str, ...], capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("COLUMNS", "80")
    with pytest.raises(SystemExit):
        main([command, "--help"])
    words = {word.strip("()") for word in capsys.readouterr().out.replace(",", " ").split()}
    assert set(names) <= words
