"""A rule declared in one place (register_agent, the shape of an entry of configs/agents.yaml) is scored by
``flownav evaluate``, tuned by the tuning study and ranked by the leaderboard, each really flown with MuJoCo on
a small image and a few layouts, as a shipped rule would be."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import pytest
from toy_agents import declared_toy_rule

from agents.analysis.records import read_records
from agents.evaluation.leaderboard import (
    against_best_reactive,
    improvements,
    leaderboard_runs,
    summarise_runs,
)
from agents.pages.leaderboard_page import report_lines
from agents.studies.tuning import tune
from agents.studies.tuning_study import Budget

SMALL = {"camera_width": 96, "camera_height": 72}
TIER = "FlowNavSingle-v0"


@pytest.fixture
def toy_rule() -> Iterator[str]:
    yield from declared_toy_rule()


def _evaluate(agent: str, out: Path, layouts: int) -> list[dict]:
    from agents.cli import main

    size = [
        "--env",
        f"camera_width={SMALL['camera_width']}",
        "--env",
        f"camera_height={SMALL['camera_height']}",
    ]
    arguments = ["evaluate", "--agent", agent, "--layouts", str(layouts), "--tiers", TIER, *size]
    assert main([*arguments, "--out", str(out)]) == 0
    return read_records(out)


def test_a_declared_rule_is_scored_and_ranked_beside_a_shipped_one(toy_rule: str, tmp_path: Path) -> None:
    rows = _evaluate(toy_rule, tmp_path / "toy.csv", 2)
    assert [row["agent"] for row in rows] == [toy_rule, toy_rule]
    # It flew on what its declaration asks for (ToyRule refuses an observation without it).
    assert all(json.loads(row["env_kwargs"])["observe_unresolved"] is True for row in rows)
    assert json.loads(rows[0]["agent_params"])["sideways"] == 0.0  # its parameters are its class's fields
    rows += _evaluate("bee", tmp_path / "bee.csv", 2)
    layouts = sorted({int(row["seed"]) for row in rows})
    runs = leaderboard_runs([toy_rule, "bee"])
    assert runs == {toy_rule: [toy_rule], "bee": ["bee"]}
    table = summarise_runs(rows, runs, layouts, block=len(layouts))
    assert [row["agent"] for row in table] == [toy_rule, "bee"] and all(row["episodes"] == 2 for row in table)
    assert (
        improvements(rows, runs, layouts, block=len(layouts)) == []
    )  # no learned agent to set against rules
    lines = report_lines(
        table, [], layouts, "test", len(layouts), against_best_reactive(table, rows, runs, layouts)
    )
    ranked = [line for line in lines if line.startswith("|") and toy_rule in line]
    assert ranked, lines


def test_a_declared_rule_is_tuned_over_its_declared_space(toy_rule: str, tmp_path: Path) -> None:
    budget = Budget(trials=2, search_episodes=1, finalists=1, final_episodes=1)
    result = tune(toy_rule, tmp_path, budget, env_id=TIER, env_kwargs=SMALL, workers=1, final_minimum=1)
    assert result.search[0].params == {
        "heading_gain": 1.5,
        "sideways": 0.0,
    }  # its defaults
    assert all(-0.3 <= trial.params["sideways"] <= 0.3 for trial in result.search)
    best = json.loads((tmp_path / "best.json").read_text())
    assert set(best) == {"heading_gain", "sideways"}
    rows = read_records(tmp_path / "episodes.csv")
    assert {row["agent"] for row in rows} == {toy_rule} and len(rows) == 2 + len(result.finals)
    assert all(json.loads(row["env_kwargs"])["observe_unresolved"] is True for row in rows)
