"""One name per concept across the commands (``--layouts``, ``--tiers``, ``--seed-start``, ``--policies-dir``,
``--agents``), each old spelling still working and saying the new one in one line; and "did you mean" for a
command, an agent name and a config key."""

from __future__ import annotations

import pytest

from agents.cli import build_parser, main
from agents.cli.arguments import env_id_of, one_tier, tier_name_of
from agents.cli.sweep import refly_agents
from agents.policies import split_agent_name
from flownav_env.tiers import TIERS


@pytest.mark.parametrize(
    ("argv", "old", "new", "dest", "value"),
    [
        (["evaluate", "--agent", "bee"], "--episodes", "--layouts", "layouts", 7),
        (["leaderboard"], "--episodes", "--layouts", "layouts", 7),
        (["ablation", "--configs", "c.yaml"], "--episodes", "--layouts", "layouts", 7),
        (["sweep"], "--episodes", "--layouts", "layouts", 7),
        (["demo"], "--episodes", "--layouts", "layouts", 7),
        (["tune", "--agent", "bee"], "--search-episodes", "--search-layouts", "search_layouts", 7),
        (["tune", "--agent", "bee"], "--final-episodes", "--final-layouts", "final_layouts", 7),
        (["evaluate", "--agent", "bee"], "--env-id", "--tiers", "tiers", "FlowNavSingle-v0"),
        (["video", "--agent", "bee"], "--env-id", "--tiers", "tiers", "hard"),
        (["tune", "--agent", "bee"], "--env-id", "--tiers", "tiers", "hard"),
        (["demo"], "--env-id", "--tiers", "tiers", "hard"),
        (["ablation", "--configs", "c.yaml"], "--tier", "--tiers", "tiers", "hard"),
        (["video", "--agent", "bee"], "--seed", "--seed-start", "seed_start", 5),
        (["bench", "env"], "--seed", "--seed-start", "seed_start", 5),
    ],
)
def test_an_old_spelling_does_what_the_new_one_does_and_says_the_new_one(
    argv: list[str], old: str, new: str, dest: str, value: object, capsys: pytest.CaptureFixture[str]
) -> None:
    parser = build_parser()
    assert getattr(parser.parse_args([*argv, new, str(value)]), dest) == value
    assert capsys.readouterr().err == ""
    assert getattr(parser.parse_args([*argv, old, str(value)]), dest) == value
    (line,) = capsys.readouterr().err.splitlines()
    assert (
        line
        == f"flownav {argv[0]}{' ' + argv[1] if argv[0] == 'bench' else ''}: {old} is an old spelling; use {new}"
    )


def test_old_spellings_are_left_out_of_the_help(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["evaluate", "--help"])
    page = capsys.readouterr().out
    assert "--layouts" in page and "--tiers" in page and "--episodes" not in page and "--env-id" not in page


def test_a_tier_is_named_by_its_name_or_its_gymnasium_id() -> None:
    hard = TIERS["hard"].env_id
    assert env_id_of("hard") == hard and env_id_of("FlowNavSingle-v0") == "FlowNavSingle-v0"
    assert tier_name_of(hard) == "hard" and tier_name_of("noisy") == "noisy"
    with pytest.raises(ValueError, match=r"^--tiers takes one tier or env id here, got 'clean,hard'$"):
        one_tier("clean,hard")


def test_describe_takes_tiers_and_its_first_spelling_a_positional_tier(
    capsys: pytest.CaptureFixture[str],
) -> None:
    hard = TIERS["hard"].env_id
    assert main(["describe", "--tiers", hard]) == 0
    captured = capsys.readouterr()
    assert captured.out.startswith(f"Tier hard ({hard})") and captured.err == ""
    assert main(["describe", "hard"]) == 0
    captured = capsys.readouterr()
    assert captured.out.startswith(f"Tier hard ({hard})")
    assert (
        captured.err.strip()
        == "flownav describe: a tier without --tiers is an old spelling; use --tiers hard"
    )


def test_the_sweep_names_the_agents_it_flies_again_with_agents(capsys: pytest.CaptureFixture[str]) -> None:
    parser = build_parser()
    args = parser.parse_args(["sweep", "--agents", "bee, vfh", "--refly"])
    assert refly_agents(args) == ["bee", "vfh"]
    with pytest.raises(ValueError, match=r"^--refly flies again the episodes of --agents AGENTS: name them$"):
        refly_agents(parser.parse_args(["sweep", "--refly"]))
    with pytest.raises(ValueError, match=r"^the sweep flies every agent of its config; --agents names"):
        refly_agents(parser.parse_args(["sweep", "--agents", "bee"]))
    # The first spelling, --refly AGENTS, still parses: run() reads it as --agents AGENTS --refly.
    assert parser.parse_args(["sweep", "--refly", "bee"]).refly == "bee"


def test_an_unknown_command_says_which_was_meant(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["evalute", "--agent", "bee"]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith(
        "flownav: error: unknown command 'evalute' (did you mean 'evaluate'?); commands: demo,"
    )


def test_an_unknown_agent_name_says_which_was_meant() -> None:
    with pytest.raises(ValueError, match=r"got 'bee_tcc'; did you mean 'bee_ttc'\?$"):
        split_agent_name("bee_tcc")
    with pytest.raises(ValueError) as far:
        split_agent_name("zzzz")
    assert "did you mean" not in str(far.value)


def test_an_unknown_config_key_says_which_was_meant() -> None:
    from agents.common.yaml_config import ConfigError, from_mapping
    from agents.training.train_config import TrainConfig

    with pytest.raises(
        ConfigError, match=r"unknown key 'ppo.gama' \(allowed at ppo: .*\); did you mean 'gamma'\?$"
    ):
        from_mapping({"name": "x", "ppo": {"gama": 0.9}}, TrainConfig, source="c.yaml")


def test_an_old_spelling_keeps_the_new_one_s_checks(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        build_parser().parse_args(["leaderboard", "--episodes", "many"])
    assert "invalid int value: 'many'" in capsys.readouterr().err
