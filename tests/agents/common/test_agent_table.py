"""The agents' names and kinds, read from configs/agents.yaml."""

from __future__ import annotations

from pathlib import Path

import pytest

from agents.common.agent_table import (
    AGENTS,
    agents_where,
    is_learned,
    read_agent_table,
    register_agent,
    seeded_agent_name,
    split_agent_name,
)


def test_kinds_come_from_the_table() -> None:
    assert agents_where(kind="rule") == ("straight", "bee", "bee_robust", "bee_ttc", "vfh")
    assert agents_where(kind="planner") == (
        "planner",
        "planner_camera",
        "planner_camera_observed",
        "planner_camera_observed_3x15",
        "planner_camera_observed_1x32",
        "planner_camera_filtered",
        "planner_camera_filtered_3x15",
    )
    assert set(agents_where(privileged=True)) == {
        name for name in AGENTS if AGENTS[name].sees in ("true_depth", "layout", "camera_view")
    }
    assert "ppo_oracle" in agents_where(kind="learned", privileged=True)
    assert (
        is_learned(seeded_agent_name("ppo_flow", 3))
        and not is_learned("bee")
        and not is_learned("pkg.mod:make")
    )
    assert split_agent_name("ppo_flow@3") == ("ppo_flow", 3)


def test_a_training_seed_on_a_rule_is_refused() -> None:
    with pytest.raises(
        ValueError, match=r"only learned agents have training seeds \(ppo_flow, .*got 'bee@1'"
    ):
        split_agent_name("bee@1")


@pytest.mark.parametrize(
    ("entry", "message"),
    [
        ("{kind: rule, sees: flow, colour: red}", r"agent 'x' has unknown keys \['colour'\]"),
        ("{kind: genius, sees: flow}", r"agent 'x' kind must be one of rule, learned, planner, got 'genius'"),
        (
            "{kind: rule}",
            r"agent 'x' sees must be one of flow, nothing, true_depth, layout, camera_view, got None",
        ),
        (
            "{kind: rule, sees: flow, per_tier: true}",
            r"agent 'x' is per_tier, which only a learned agent can be",
        ),
        (
            "{kind: learned, sees: true_depth, not_flown_on: {2: not needed}}",
            r"agent 'x' not_flown_on must map suite versions \(quoted, such as \"2\"\) to why, got \{2: 'not needed'\}",
        ),
        ('{kind: rule, sees: flow, not_flown_on: ["2"]}', r"agent 'x' not_flown_on must map suite versions"),
        (
            "{kind: rule, sees: flow}",
            r"agent 'x' is a rule, so its class must be written package.module:ClassName, got None$",
        ),
        (
            "{kind: planner, sees: layout, class: planner.py}",
            r"agent 'x' is a planner, so its class must be written package.module:ClassName, got 'planner.py'$",
        ),
        (
            "{kind: learned, sees: flow, class: 'a.b:C', env: {observe_unresolved: true}}",
            r"agent 'x' is learned \(its policy is a file\), so it takes none of class, env, search_space, "
            r"fixed_gains, got class, env$",
        ),
        (
            "{kind: rule, sees: flow, class: 'a.b:C', env: [observe_unresolved]}",
            r"agent 'x' env must map env settings to values \(such as observe_unresolved: true\), got "
            r"\['observe_unresolved'\]$",
        ),
        (
            "{kind: rule, sees: flow, class: 'a.b:C', search_space: {gain: [2.0, 1.0, log]}}",
            r"agent 'x' search_space gain must be \[low, high, log or linear\] with low < high, got "
            r"\[2.0, 1.0, 'log'\]$",
        ),
        (
            "{kind: rule, sees: flow, class: 'a.b:C', search_space: {gain: [0.1, 1.0, logarithmic]}}",
            r"agent 'x' search_space gain must be \[low, high, log or linear\] with low < high, got",
        ),
        (
            "{kind: rule, sees: flow, class: 'a.b:C', search_space: {}}",
            r"agent 'x' search_space must map gains to \[low, high, log or linear\], got \{\}$",
        ),
        (
            "{kind: rule, sees: flow, class: 'a.b:C', fixed_gains: 'yes'}",
            r"agent 'x' fixed_gains must be true or false, got 'yes'$",
        ),
    ],
)
def test_a_bad_entry_is_refused(tmp_path: Path, entry: str, message: str) -> None:
    path = tmp_path / "agents.yaml"
    path.write_text(f"agents:\n  x: {entry}\n")
    with pytest.raises(ValueError, match=message):
        read_agent_table(path)


def test_the_suite_versions_an_agent_is_not_flown_on_are_read_with_why(tmp_path: Path) -> None:
    path = tmp_path / "agents.yaml"
    path.write_text('agents:\n  x: {kind: learned, sees: true_depth, not_flown_on: {"2": not needed}}\n')
    (entry,) = read_agent_table(path)
    assert entry.not_flown_on == (("2", "not needed"),)


def test_a_registered_entry_is_checked_as_the_table_checks_one() -> None:
    with pytest.raises(
        ValueError, match=r"^register_agent: agent 'x' kind must be one of rule, learned, planner"
    ):
        register_agent("x", {"kind": "genius", "sees": "flow"})
    assert "x" not in AGENTS


def test_the_table_reads_each_rules_class_env_and_search_space(tmp_path: Path) -> None:
    path = tmp_path / "agents.yaml"
    path.write_text(
        "agents:\n  x:\n    kind: rule\n    sees: flow\n    class: a.b:C\n    env: {observe_unresolved: true}\n"
        "    search_space: {gain: [0.1, 2.0, log], rows: [1, 3, linear]}\n"
    )
    (entry,) = read_agent_table(path)
    assert entry.class_path == "a.b:C" and entry.env == (("observe_unresolved", True),) and entry.tunable
    assert entry.search_space == (("gain", (0.1, 2.0, True)), ("rows", (1, 3, False)))
