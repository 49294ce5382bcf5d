"""flownav tune: the study on training seeds only, resumable without re-flying, and its outputs."""

from __future__ import annotations

import dataclasses
import hashlib
import json
from collections import Counter
from pathlib import Path

import pytest

import flownav_env  # noqa: F401  (before mujoco)
from agents.analysis.records import episode_key, read_records
from agents.common.seeds import VALIDATION_SEED_START
from agents.evaluation import runner
from agents.evaluation.episode import EpisodeRecord
from agents.evaluation.episode_tasks import EpisodeTask, canonical_json
from agents.evaluation.runner import EpisodesInterrupted
from agents.policies.registry import search_space, tunable_agents
from agents.studies.tuning import TuningResult, comparison, report_text, tune
from agents.studies.tuning_study import (
    Budget,
    TrialResult,
    default_params,
    distributions,
)

TINY = Budget(trials=6, search_episodes=3, finalists=2, final_episodes=4)


def fake_flights(monkeypatch, interrupt_after: int | None = None) -> list[EpisodeTask]:
    """Replace the flight by a draw that depends only on the gains and the seed, so a study runs in
    milliseconds and is as deterministic as a real one; returns the tasks it flew, in order."""
    flown: list[EpisodeTask] = []

    def fly(task: EpisodeTask) -> EpisodeRecord:
        if interrupt_after is not None and len(flown) == interrupt_after:
            raise KeyboardInterrupt
        flown.append(task)
        digest = hashlib.sha256(canonical_json([task.bee_params, task.seed]).encode()).hexdigest()
        draw = int(digest, 16) % 100 / 100
        success, collision = draw < 0.5, 0.5 <= draw < 0.8
        return EpisodeRecord(
            task.agent, task.factor, task.level, task.seed, collision, success, not success and not collision,
            False, 20.0 * draw, 10.0, 100, 0.5, 20.0, 50.0, 0.1, 1.0, **task.identity(), code_version="test",
        )  # fmt: skip

    monkeypatch.setattr(runner, "run_task", fly)
    return flown


def run_tiny(out: Path, agent: str = "bee", budget: Budget = TINY, **kwargs) -> TuningResult:
    return tune(agent, out, budget, workers=1, final_minimum=1, **kwargs)


def study_of(result: TuningResult) -> list:
    return [[(t.number, t.params, t.summary) for t in stage] for stage in (result.search, result.finals)]


def test_search_spaces_hold_the_defaults_and_match_the_command_line() -> None:
    from agents.cli.tune import TUNABLE_AGENTS as CLI_AGENTS

    assert CLI_AGENTS == tunable_agents() == ("bee", "bee_robust", "vfh")
    for agent in tunable_agents():
        defaults = default_params(agent)
        for name, (low, high, _) in search_space(agent).items():
            assert low <= defaults[name] <= high, (agent, name)
    assert type(distributions("vfh")["obstacle_rows"]).__name__ == "IntDistribution"
    assert {"quantile", "smoothing"} <= set(search_space("bee_robust")) and set(search_space("bee")) < set(
        search_space("bee_robust")
    )


@pytest.mark.parametrize(
    ("agent", "budget", "workers", "message"),
    [
        ("straight", Budget(), 1, "--agent must be one of bee, bee_robust, vfh, got 'straight'"),
        ("bee", Budget(trials=0), 1, "--trials must be an integer >= 1, got 0"),
        ("bee", Budget(search_episodes=0), 1, "--search-layouts must be an integer >= 1, got 0"),
        ("bee", Budget(trials=3, finalists=4), 1, "--finalists must be in [1, --trials = 3], got 4"),
        ("bee", Budget(finalists=0), 1, "--finalists must be in [1, --trials = 40], got 0"),
        ("bee", Budget(final_episodes=50), 1, "--final-layouts must be >= 100, got 50"),
        (
            "bee",
            Budget(search_episodes=400_000, final_episodes=100_001),
            1,
            "--search-layouts + --final-layouts must stay within the training seeds [0, 500000), "
            "got 400000 + 100001 = 500001 layouts",
        ),
        ("vfh", Budget(), 0, "--workers must be an integer >= 1, got 0"),
    ],
)
def test_bad_input_names_the_value_and_its_range(
    agent: str, budget: Budget, workers: int, message: str, tmp_path: Path
) -> None:
    with pytest.raises(ValueError) as error:
        tune(agent, tmp_path / "out", budget, workers=workers)
    assert str(error.value) == message
    assert not (tmp_path / "out").exists()


def test_the_command_line_reports_bad_input_in_one_line(capsys) -> None:
    from agents.cli import main

    assert main(["tune", "--agent", "bee", "--final-layouts", "50"]) == 2
    assert "flownav tune: error: --final-layouts must be >= 100, got 50" in capsys.readouterr().err


def test_the_largest_budget_ends_just_below_the_validation_seeds() -> None:
    budget = Budget(search_episodes=VALIDATION_SEED_START - 100, final_episodes=100)
    budget.check()
    search, final = budget.layout_seeds()
    assert final.stop == VALIDATION_SEED_START and search.stop == final.start


def test_layouts_are_training_seeds_shared_within_a_stage_and_disjoint_across(
    tmp_path: Path, monkeypatch
) -> None:
    fake_flights(monkeypatch)
    result = run_tiny(tmp_path)
    rows = read_records(tmp_path / "episodes.csv")
    seeds: dict[tuple[str, float], set[int]] = {}
    for row in rows:
        seeds.setdefault((row["factor"], row["level"]), set()).add(row["seed"])
    search = {seeds[key] == {0, 1, 2} for key in seeds if key[0] == "search"}
    final = [frozenset(seeds[key]) for key in seeds if key[0] == "final"]
    assert search == {True} and len(final) == len(result.finals) and set(final) == {frozenset({3, 4, 5, 6})}
    assert all(0 <= row["seed"] < VALIDATION_SEED_START for row in rows)
    # Trial 0 is the defaults, and the defaults are always a finalist.
    assert result.search[0].params == default_params("bee")
    assert json.loads(rows[0]["agent_params"]).items() >= default_params("bee").items()
    assert result.defaults.params == default_params("bee")
    assert [t.number for t in result.search] == list(range(TINY.trials))
    assert result.winner.rank() == min(t.rank() for t in result.finals)


def test_a_resumed_study_equals_an_uninterrupted_one_and_flies_nothing_twice(
    tmp_path: Path, monkeypatch
) -> None:
    # More trials than TPE's 10 random start-up ones, so the replay also covers its model-based proposals.
    budget = dataclasses.replace(TINY, trials=14)
    fake_flights(monkeypatch)
    whole = run_tiny(tmp_path / "whole", budget=budget)
    runs = []
    for interrupt_after in (7, 38):  # once in the search, once in the final stage (42 search episodes)
        runs.append(fake_flights(monkeypatch, interrupt_after))
        with pytest.raises(EpisodesInterrupted, match="run the same command again to resume"):
            run_tiny(tmp_path / "resumed", budget=budget)
    runs.append(fake_flights(monkeypatch))
    resumed = run_tiny(tmp_path / "resumed", budget=budget)
    assert study_of(resumed) == study_of(whole)
    flown = [task for run in runs for task in run]
    assert [len(run) for run in runs] == [7, 38, len(flown) - 45] and len(flown) > 45
    rows = read_records(tmp_path / "resumed" / "episodes.csv")
    assert len(flown) == len(rows) == len(read_records(tmp_path / "whole" / "episodes.csv"))
    assert max(Counter(episode_key(row) for row in rows).values()) == 1
    again = fake_flights(monkeypatch)  # a finished study run again flies nothing
    assert study_of(run_tiny(tmp_path / "resumed", budget=budget)) == study_of(whole) and again == []


def test_overwrite_moves_the_old_episodes_aside(tmp_path: Path, monkeypatch, capsys) -> None:
    fake_flights(monkeypatch)
    run_tiny(tmp_path)
    flights = fake_flights(monkeypatch)
    run_tiny(tmp_path, overwrite=True)
    assert "--overwrite: moved" in capsys.readouterr().out
    assert len(list(tmp_path.glob("episodes.csv.bak-*"))) == 1
    assert len(flights) == len(read_records(tmp_path / "episodes.csv"))


def _trial(number: int, failures: int, episodes: int = 150) -> TrialResult:
    from agents.analysis.statistics import summarise

    base = {
        "agent": "bee",
        "factor": "final",
        "out_of_bounds": False,
        "progress_m": 1.0,
        "min_clearance_m": 1.0,
    }
    rows = [
        {**base, "level": number, "collision": i < failures, "success": i >= failures}
        for i in range(episodes)
    ]
    failures = tuple(float(i < failures) for i in range(episodes))
    return TrialResult(number, dict.fromkeys(search_space("bee"), 0.1 * number), summarise(rows)[0], failures)


def test_the_verdict_is_the_paired_test_on_the_final_layouts() -> None:
    def verdict(result: TuningResult) -> str:
        text = report_text(result, Budget(), "flownav tune", {}, 0)
        return text.split("(in `best.json`).\n\n")[1].split("\n")[0]

    finals = [_trial(3, 30), _trial(0, 90)]
    clear = TuningResult("bee", finals, finals)
    found = comparison(clear)
    assert found is not None and found.difference == pytest.approx(-60 / 150) and found.fails_less == "winner"
    assert verdict(clear).startswith(
        "The winner (trial 3) fails less than the defaults on the same final layouts"
    )
    finals = [_trial(3, 88), _trial(0, 90)]
    close = TuningResult("bee", finals, finals)
    assert verdict(close).startswith("The winner (trial 3) is not shown to fail less than the defaults")
    assert "paired by layout, winner − defaults = -0.013 [" in verdict(close)
    finals = [_trial(0, 80), _trial(3, 90)]
    defaults_won = TuningResult("bee", finals, finals)
    assert comparison(defaults_won) is None and verdict(defaults_won).startswith("The defaults")


def test_a_real_study_writes_every_output(tmp_path: Path) -> None:
    budget = Budget(trials=2, search_episodes=2, finalists=1, final_episodes=2)
    small = {"camera_width": 96, "camera_height": 72}
    result = tune(
        "vfh", tmp_path, budget, env_id="FlowNavSingle-v0", env_kwargs=small, workers=1, final_minimum=1
    )
    rows = read_records(tmp_path / "episodes.csv")
    assert len(rows) == 2 * 2 + 2 * len(result.finals) and {row["agent"] for row in rows} == {"vfh"}
    best = json.loads((tmp_path / "best.json").read_text())
    assert best == result.winner.params and set(best) == set(search_space("vfh"))
    assert isinstance(best["obstacle_rows"], int)
    from agents.policies import VFHAgent

    VFHAgent(**best)
    report = (tmp_path / "tuning.md").read_text()
    assert "Command: `flownav tune --agent vfh --trials 2 --search-episodes 2 --finalists 1 " in report
    assert "| 0 (defaults) |" in report and "Winner: trial" in report and "95 % CI" in report
    assert report.splitlines() == result.lines
    assert (tmp_path / "tuning_curve.png").stat().st_size > 10_000
