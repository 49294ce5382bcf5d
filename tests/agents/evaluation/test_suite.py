"""Scoring any agent on the suite's frozen layouts: the tasks, the table, score.csv and leaderboard --include."""

from __future__ import annotations

import csv
import json
import re
from dataclasses import replace
from pathlib import Path

import pytest

from agents.analysis.records import append_record, read_records
from agents.cli import main
from agents.common.seeds import (
    CONFIRMATION_SEED_START,
    SUITE_LAYOUTS,
    SUITE_SEED_START,
    TEST_SEED_START,
    TIER_CALIBRATION_SEED_START,
    VALIDATION_SEED_START,
    suite_seeds,
)
from agents.evaluation.episode import EpisodeRecord
from agents.evaluation.scoring import score
from agents.evaluation.suite import (
    RUNS_INTERVAL,
    SUMMARY_COLUMNS,
    parse_tiers,
    run_suite,
    suite_agents,
    suite_rows,
    suite_tasks,
    summarise_suite,
)
from agents.evaluation.suite_report import SuiteRow, merge_rows, outcome_interval, read_suite_csv
from flownav_env.tiers import SUITE_VERSION, TIERS

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "open_gap_agent.py"


def test_the_frozen_layouts_are_test_seeds_apart_from_every_other_range() -> None:
    assert VALIDATION_SEED_START <= CONFIRMATION_SEED_START < TIER_CALIBRATION_SEED_START < TEST_SEED_START
    assert list(suite_seeds(3)) == [SUITE_SEED_START, SUITE_SEED_START + 1, SUITE_SEED_START + 2]
    assert SUITE_SEED_START >= TEST_SEED_START + 1_000 * 300  # past every layout the earlier tables flew
    for bad in (0, SUITE_LAYOUTS + 1, 2.5, True):
        with pytest.raises(
            ValueError, match=re.escape(f"suite layouts must be an integer in [1, {SUITE_LAYOUTS}], got")
        ):
            suite_seeds(bad)


def test_tiers_parse_from_all_or_names_in_suite_order() -> None:
    assert parse_tiers("all") == list(TIERS)
    assert parse_tiers("noisy, hard") == ["hard", "noisy"]
    with pytest.raises(ValueError, match="tier must be one of clean, hard, noisy, hard_noisy, got 'medium'"):
        parse_tiers("hard,medium")
    with pytest.raises(ValueError, match="give at least one tier"):
        parse_tiers(" , ")


def test_suite_tasks_carry_the_tier_settings_and_the_suite_version() -> None:
    tasks = suite_tasks({"bee": ["bee"]}, ["hard_noisy"], layouts=2)
    assert [t.seed for t in tasks] == [SUITE_SEED_START, SUITE_SEED_START + 1]
    task = tasks[0]
    assert task.factor == "hard_noisy" and task.env_id == "FlowNavHardNoisy-v1"
    assert dict(task.env_kwargs) == TIERS["hard_noisy"].settings and task.suite_version == SUITE_VERSION
    assert task.tier == "hard_noisy" and replace(task, suite_version="").tier == ""


def test_suite_rows_read_the_tier_from_the_stored_factor_column(tmp_path: Path) -> None:
    # The episodes CSV has no tier column: a suite episode's tier is stored as its factor, at level 0.
    (task,) = suite_tasks({"bee": ["bee"]}, ["noisy"], layouts=1)
    record = EpisodeRecord(
        task.agent, task.factor, task.level, task.seed, False, True, False, False,
        20.0, 20.0, 200, 0.5, 20.0, 100.0, 0.04, 30.0, **task.identity(), suite_version=task.suite_version,
    )  # fmt: skip
    append_record(tmp_path / "episodes.csv", record)
    (row,) = suite_rows([task], tmp_path / "episodes.csv")
    assert (row["tier"], row["factor"], row["level"]) == ("noisy", "noisy", 0.0)


def test_an_agent_that_changes_what_a_tier_fixes_is_refused(tmp_path: Path) -> None:
    agent_file = tmp_path / "fast_agent.py"
    agent_file.write_text(
        "import numpy as np\n"
        "class Fast:\n"
        "    env_settings = {'forward_speed': 1.0}\n"
        "    def predict(self, observation, state=None, episode_start=None, deterministic=True):\n"
        "        return np.zeros(3, np.float32), state\n"
        "def make():\n    return Fast()\n"
    )
    with pytest.raises(
        ValueError, match=re.escape("asks for forward_speed=1.0, but tier hard fixes forward_speed=2.0")
    ):
        score(f"{agent_file}:make", tiers="hard", layouts=1, out=tmp_path / "out")


def test_a_retired_agent_is_neither_flown_nor_reported_by_the_suite(tmp_path: Path) -> None:
    from agents.policies import RETIRED_AGENTS, SUITE_AGENTS

    retired = next(iter(RETIRED_AGENTS))
    assert retired not in SUITE_AGENTS and retired not in suite_agents()
    for name in (retired, f"{retired}@0"):
        with pytest.raises(ValueError, match=re.escape(f"{name!r} is retired from the suite (")):
            run_suite([name], tmp_path / "out", tiers="hard", layouts=1)
    assert not (tmp_path / "out").exists()  # refused before anything is written


def test_an_agent_a_suite_version_does_not_fly_is_refused_there_and_flown_on_the_others(
    tmp_path: Path,
) -> None:
    from agents.policies import NOT_FLOWN_ON

    skipped, why = next(iter(NOT_FLOWN_ON["2"].items()))
    assert skipped not in suite_agents("2") and skipped in suite_agents("1")
    for name in (skipped, f"{skipped}@0"):
        with pytest.raises(
            ValueError, match=re.escape(f"{name!r} is not flown on suite v2 ({why}); name an")
        ):
            run_suite([name], tmp_path / "out", tiers="hard", layouts=1, version="2")
    assert not (tmp_path / "out").exists()  # refused before anything is written
    # The command's default asks for what the version flies, so it never names one refused above.
    from agents.cli import build_parser

    assert build_parser().parse_args(["suite"]).agents is None


def _row(agent: str, tier: str, failure: float, version: str = SUITE_VERSION) -> dict:
    row = {name: 0.0 for name in SUMMARY_COLUMNS}
    row.update(suite_version=version, tier=tier, env_id=TIERS[tier].env_id, agent=agent, runs=1, layouts=30)
    row.update(episodes=30, interval_over="layouts (Wilson)", failure_rate=failure, success_rate=1 - failure)
    low, high = max(failure - 0.1, 0.0), min(failure + 0.1, 1.0)
    # Every failure a collision: the exclusive outcomes' rates sum to 1, each inside its interval.
    row.update(
        failure_low=low, failure_high=high, collision_rate=failure, collision_low=low, collision_high=high
    )
    row.update(success_low=1 - high, success_high=1 - low)
    row.update(env_kwargs=json.dumps(TIERS[tier].settings), privileged=False)
    return row


def _write(path: Path, rows: list[dict]) -> Path:
    with path.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=SUMMARY_COLUMNS)
        writer.writeheader()
        writer.writerows(rows)
    return path


def test_summaries_pool_training_seeds_and_leave_out_unfinished_agents() -> None:
    seeds = list(suite_seeds(2))
    rows = [
        {
            "agent": run,
            "tier": "hard",
            "seed": seed,
            "success": run == "ppo_flow@0" or seed == seeds[0],
            "collision": False,
            "out_of_bounds": not (run == "ppo_flow@0" or seed == seeds[0]),
            "env_kwargs": '{"forward_speed":2.0,"obstacle_density":0.18}',
        }
        for run in ("ppo_flow@0", "ppo_flow@1")
        for seed in seeds
    ]
    rows.append(
        {
            "agent": "bee",
            "tier": "hard",
            "seed": seeds[0],
            "success": True,
            "collision": False,
            "out_of_bounds": False,
            "env_kwargs": '{"forward_speed":2.0,"obstacle_density":0.18}',
        }
    )
    table = summarise_suite(
        rows, {"ppo_flow": ["ppo_flow@0", "ppo_flow@1"], "bee": ["bee"]}, ["hard"], layouts=2
    )
    assert [row["agent"] for row in table] == ["ppo_flow"]  # bee has not flown layout 2
    (row,) = table
    assert row["runs"] == 2 and row["episodes"] == 4 and row["failure_rate"] == 0.25
    assert row["out_of_bounds_rate"] == 0.25 and row["interval_over"] == RUNS_INTERVAL
    assert row["failure_low"] <= 0.25 <= row["failure_high"]
    assert row["privileged"] is False and row["env_kwargs"] == '{"forward_speed":2.0,"obstacle_density":0.18}'
    assert row["timeout_rate"] == 0.0
    assert (
        sum(row[f"{outcome}_rate"] for outcome in ("success", "collision", "out_of_bounds", "timeout")) == 1
    )


def test_the_example_agent_is_scored_end_to_end_and_included_beside_the_published_rows(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "score"
    code = main(
        [
            "score",
            "--agent",
            f"{EXAMPLE}:make_agent",
            "--tiers",
            "hard",
            "--layouts",
            "2",
            "--workers",
            "1",
            "--out",
            str(out),
        ]
    )
    assert code == 0
    (row,) = read_suite_csv(out / "score.csv")
    assert row["tier"] == "hard" and row["layouts"] == 2 and row["suite_version"] == SUITE_VERSION
    episodes = read_records(out / "suite_episodes.csv")
    assert len(episodes) == 2 and {e["suite_version"] for e in episodes} == {SUITE_VERSION}
    assert row["failure_rate"] == sum(not e["success"] for e in episodes) / 2
    # Again: resumes, flies nothing, same rows.
    assert (
        main(
            [
                "score",
                "--agent",
                f"{EXAMPLE}:make_agent",
                "--tiers",
                "hard",
                "--layouts",
                "2",
                "--workers",
                "1",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    assert len(read_records(out / "suite_episodes.csv")) == 2
    published = _write(tmp_path / "suite.csv", [_row("bee_ttc", "hard", 0.3), _row("bee", "clean", 0.1)])
    capsys.readouterr()
    assert (
        main(
            [
                "leaderboard",
                "--suite",
                str(published),
                "--include",
                str(out / "score.csv"),
                "--out",
                str(tmp_path / "board"),
            ]
        )
        == 0
    )
    text = (tmp_path / "board" / "suite_with_included.md").read_text()
    assert "`open_gap_agent:make_agent` (included, self-reported)" in text and "`bee_ttc`" in text
    assert (tmp_path / "board" / "suite_with_included.png").stat().st_size > 0


def test_included_rows_of_another_suite_version_or_file_kind_are_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    published = _write(tmp_path / "suite.csv", [_row("bee_ttc", "hard", 0.3)])
    other = _write(tmp_path / "old.csv", [_row("mine", "hard", 0.2, version="0")])
    assert (
        main(["leaderboard", "--suite", str(published), "--include", str(other), "--out", str(tmp_path)]) == 2
    )
    assert (
        f"holds rows of suite version '0', but this is suite version '{SUITE_VERSION}'"
        in capsys.readouterr().err
    )
    foreign = tmp_path / "foreign.csv"
    foreign.write_text("agent,failure\nmine,0.2\n")
    assert (
        main(["leaderboard", "--suite", str(published), "--include", str(foreign), "--out", str(tmp_path)])
        == 2
    )
    assert (
        "is not a suite CSV (flownav score writes one): it lacks the columns suite_version"
        in capsys.readouterr().err
    )


def test_an_included_row_replaces_the_published_row_of_its_agent_and_tier() -> None:
    merged = merge_rows([_row("bee", "hard", 0.5), _row("bee_ttc", "hard", 0.3)], [_row("bee", "hard", 0.2)])
    assert [(r["agent"], r["failure_rate"], r.get("included", False)) for r in merged] == [
        ("bee", 0.2, True),
        ("bee_ttc", 0.3, False),
    ]


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (
            ["--agent", "no_such_package.module:make"],
            "cannot import the agent module 'no_such_package.module'",
        ),
        (
            ["--agent", "bee", "--tiers", "medium"],
            "tier must be one of clean, hard, noisy, hard_noisy, got 'medium'",
        ),
        (["--agent", "bee", "--layouts", "0"], "suite layouts must be an integer in [1, 300], got 0"),
        (["--algo", "sac"], "--algo goes with --policy model.zip and without --agent"),
        ([], "give --agent (or --policy model.zip --algo ALGO)"),
    ],
)
def test_bad_score_input_is_one_line(
    argv: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["score", *argv, "--out", str(tmp_path)]) == 2
    error = capsys.readouterr().err
    assert message in error and error.count("\n") == 1


def test_an_agent_without_predict_or_missing_a_key_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    agent_file = tmp_path / "agents.py"
    agent_file.write_text(
        "import numpy as np\n"
        "class ReadsApproach:\n"
        "    def predict(self, observation, state=None, episode_start=None, deterministic=True):\n"
        "        return np.clip(observation['approach'][:3], -1, 1), state\n"
        "class NoPredict:\n    pass\n"
        "def reads_approach():\n    return ReadsApproach()\n"
        "def no_predict():\n    return NoPredict()\n"
    )
    common = ["--tiers", "hard", "--layouts", "1", "--workers", "1", "--out", str(tmp_path / "out")]
    assert main(["score", "--agent", f"{agent_file}:no_predict", *common]) == 2
    error = capsys.readouterr().err
    assert "gave a NoPredict, which has no predict(observation, state, episode_start, deterministic)" in error
    assert main(["score", "--agent", f"{agent_file}:reads_approach", *common]) == 2
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert error == (
        "flownav score: error: the agent reads observation key 'approach', which this env does not give: declare "
        "env_settings = {'observe_approach': True} on the agent (or make the env with observe_approach=True) in "
        f"the episode on tier hard, layout seed {suite_seeds(1)[0]}"
    )


def _agent_file(path: Path, settings: dict, privileged: bool = False) -> Path:
    path.write_text(
        "import numpy as np\n"
        "class Straight:\n"
        f"    env_settings = {settings!r}\n"
        f"    privileged = {privileged!r}\n"
        "    def predict(self, observation, state=None, episode_start=None, deterministic=True):\n"
        "        return np.array([1.0, 0.0, 0.0], np.float32), state\n"
        "def make():\n    return Straight()\n"
    )
    return path


@pytest.mark.parametrize("tier_name", ["clean", "noisy"])
def test_an_agent_cannot_empty_the_field_on_a_tier_that_names_no_course(
    tier_name: str, tmp_path: Path
) -> None:
    agent = _agent_file(tmp_path / "empty_field.py", {"obstacle_density": 0.0})
    with pytest.raises(
        ValueError,
        match=re.escape(f"asks for obstacle_density=0.0, but tier {tier_name} fixes obstacle_density=0.12"),
    ):
        score(f"{agent}:make", tiers=tier_name, layouts=1, out=tmp_path / "out")
    assert not (tmp_path / "out" / "suite_episodes.csv").exists()  # refused before anything flew


def test_true_depths_need_a_declared_privileged_agent_whose_rows_say_so(tmp_path: Path) -> None:
    undeclared = _agent_file(tmp_path / "peeks.py", {"obs_source": "oracle"})
    with pytest.raises(ValueError, match=re.escape("asks for obs_source='oracle', privileged data")):
        score(f"{undeclared}:make", tiers="clean", layouts=1, out=tmp_path / "undeclared")
    declared = _agent_file(tmp_path / "reference.py", {"obs_source": "oracle"}, privileged=True)
    (row,) = score(f"{declared}:make", tiers="clean", layouts=1, out=tmp_path / "declared")
    assert row["privileged"] is True
    assert json.loads(row["env_kwargs"]) == {**TIERS[row["tier"]].settings, "obs_source": "oracle"}
    (again,) = read_suite_csv(tmp_path / "declared" / "score.csv")
    assert again["privileged"] is True


def test_included_rows_flown_with_other_settings_are_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    published = _write(tmp_path / "suite.csv", [_row("bee_ttc", "hard", 0.3)])
    changed = _row("mine", "hard", 0.0)
    changed["env_kwargs"] = json.dumps({**TIERS["hard"].settings, "obstacle_density": 0.0})
    peeking = _row("peek", "noisy", 0.0)
    peeking["env_kwargs"] = json.dumps({**TIERS["noisy"].settings, "obs_source": "oracle"})
    for name, row, message in [
        ("changed.csv", changed, "agent mine was flown on tier hard with obstacle_density=0.0"),
        ("peeking.csv", peeking, "agent peek asks for obs_source='oracle', privileged data"),
    ]:
        included = _write(tmp_path / name, [row])
        argv = ["leaderboard", "--suite", str(published), "--include", str(included), "--out", str(tmp_path)]
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert f"{included}: {message}" in err and len(err.strip().splitlines()) == 1


def test_a_suite_rows_fields_are_the_summary_columns_then_the_included_mark() -> None:
    assert list(SuiteRow.__annotations__) == [*SUMMARY_COLUMNS, "included"]


def test_an_outcomes_interval_is_read_from_its_three_columns() -> None:
    row = _row("bee", "hard", 0.25)
    assert outcome_interval(row, "failure") == (row["failure_rate"], row["failure_low"], row["failure_high"])
