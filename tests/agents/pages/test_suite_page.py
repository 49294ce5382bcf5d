"""suite.md's values and every branch of its template: ranked, provisional and reference rows, top groups,
headroom and what is not yet flown."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from agents.analysis.paired import MIN_RANKED_SEEDS
from agents.common.seeds import suite_seeds
from agents.evaluation.suite_ranking import rank_suite
from agents.evaluation.suite_report import SUMMARY_COLUMNS
from agents.pages.suite_page import (
    STUDENT_RECIPES_DIR,
    camera_student_recipe_reports,
    student_recipe_reports,
    suite_page,
    suite_values,
)
from agents.pages.suite_types import SuiteValues
from flownav_env.tiers import SUITE_VERSION, TIERS


def _row(agent: str, tier: str, matrix: np.ndarray, privileged: bool = False) -> dict:
    row = {name: 0.0 for name in SUMMARY_COLUMNS}
    rate = float(matrix.mean())
    row.update(tier=tier, agent=agent, runs=matrix.shape[0], layouts=matrix.shape[1], privileged=privileged)
    row.update(failure_rate=rate, success_rate=1 - rate, collision_rate=rate, env_kwargs=json.dumps({}))
    return row


def _values(missing: list[str]) -> SuiteValues:
    rng = np.random.default_rng(0)
    matrices = {
        "bee_ttc": (rng.random((1, 60)) < 0.3).astype(float),
        "straight": np.ones((1, 60)),
        "ppo_flow": (rng.random((MIN_RANKED_SEEDS - 5, 60)) < 0.1).astype(float),
        "ppo_oracle": np.zeros((5, 60)),
    }
    table = [_row(agent, "hard", m, privileged=agent == "ppo_oracle") for agent, m in matrices.items()]
    rankings = rank_suite(table, {"hard": matrices})
    return suite_values(
        table,
        rankings,
        command="flownav suite --report-only",
        layouts=suite_seeds(60),
        machine="a test machine",
        missing=missing,
        generated="today",
        bounds={},
    )


def test_references_and_provisional_agents_are_listed_apart_and_never_best() -> None:
    values = _values([])
    (hard,) = values.tiers
    assert hard.best["agent"] == "bee_ttc" and hard.top_group == ["bee_ttc"]
    assert [row["agent"] for row in hard.ranked] == ["bee_ttc", "straight"]
    assert [row["agent"] for row in hard.provisional] == ["ppo_flow"]
    assert [row["agent"] for row in hard.references] == ["ppo_oracle"]
    assert hard.room is True and hard.env_id == TIERS["hard"].env_id


def test_the_page_renders_every_branch() -> None:
    with_missing = suite_page(_values(["bee on noisy"]))
    assert "No learned agent is ranked on `hard`" in with_missing
    for section in ("## Top groups", "Provisional, not ranked", "References, privileged", "## Not yet flown"):
        assert section in with_missing
    assert "`bee on noisy`" in with_missing and "top group `bee_ttc`" in with_missing
    assert "## Not yet flown" not in suite_page(_values([]))
    table_lines = [line for line in with_missing.splitlines() if line.startswith("|")]
    header = table_lines[0]
    rule = table_lines[1]
    assert header.count("|") == rule.count("|")  # every column has its rule


def test_the_reading_section_pairs_the_committed_flights_by_layout() -> None:
    from agents.common.locations import RESULTS_DIR
    from agents.pages.suite_page import SENSOR_READING_DIR, reading_values
    from flownav_env.sensor_specs import VELOCITY_READINGS, translation_noise_m

    readings = reading_values(RESULTS_DIR / "suite_v1" / SENSOR_READING_DIR)
    assert {r["agent"] for r in readings} >= {"bee_ttc"}
    for row in readings:
        assert row["layouts"] == 100 and row["first_seed"] >= 500_000  # validation layouts only
        assert row["noise_m"] == translation_noise_m(VELOCITY_READINGS["3d_speed"][1])
        assert row["comparison"].difference == pytest.approx(row["failure"] - row["suite_failure"])
    page = suite_page(dataclasses.replace(_values([]), readings=readings))
    assert "## How much of the noisy tier rests on one reading of one specification" in page
    assert "## How much of the noisy tier" not in suite_page(_values([]))


def test_the_bound_section_classifies_each_planner_failure_by_the_independent_check() -> None:
    from agents.evaluation.tier_bound import tier_bound

    layouts = list(suite_seeds(60))
    planner = np.zeros((1, 60))
    planner[0, [3, 7]] = 1.0  # fails two layouts: the check calls the first infeasible
    best = np.ones((1, 60))
    best[0, :30] = 0.0
    bound = tier_bound("hard", planner, "bee_ttc", best, layouts, feasible=lambda _, seed: seed != layouts[3])
    assert (bound["failed"], bound["infeasible"], bound["misses"]) == (2, 1, 1)
    assert bound["infeasible_share"] == pytest.approx(1 / 60)
    assert bound["gap"].difference == pytest.approx(0.5 - 2 / 60) and bound["gap"].low > 0
    values = _values([])
    page = suite_page(dataclasses.replace(values, tiers=[dataclasses.replace(values.tiers[0], bound=bound)]))
    assert "## What each tier allows" in page and "| `hard` | 0.03 [" in page
    assert "## What each tier allows" not in suite_page(_values([]))


def test_a_real_layout_is_checked_from_the_envs_privileged_keys() -> None:
    from agents.common.seeds import PLANNER_TUNING_SEED_START
    from agents.evaluation.tier_bound import layout_is_feasible

    assert (
        layout_is_feasible("hard", PLANNER_TUNING_SEED_START) is True
    )  # the planner flies it without a miss


def test_each_row_says_which_tiers_its_agent_trained_on() -> None:
    (hard,) = _values([]).tiers
    rows = {row["agent"]: row for row in [*hard.ranked, *hard.provisional, *hard.references]}
    assert rows["bee_ttc"]["trained_on"] == "—"
    assert rows["ppo_flow"]["trained_on"] == "v1: clean (none of v2's)"  # FlowNav-v0 with its defaults


def test_the_page_sets_the_best_learned_agent_against_the_best_rule() -> None:
    from agents.evaluation.learning_gain import learning_gain

    rng = np.random.default_rng(3)
    matrices = {
        "bee_ttc": (rng.random((1, 120)) < 0.4).astype(float),
        "ppo_flow": (rng.random((10, 120)) < 0.1).astype(float),
    }
    table = [_row(agent, "hard", matrix) for agent, matrix in matrices.items()]
    rankings = rank_suite(table, {"hard": matrices})
    gain = learning_gain("hard", matrices, rankings["hard"])
    assert gain is not None
    text = suite_page(
        suite_values(
            table,
            rankings,
            command="flownav suite --report-only",
            layouts=suite_seeds(120),
            machine="a test machine",
            missing=[],
            generated="today",
            gains=[gain],
        )
    )
    assert "| `hard` | `ppo_flow` | v1: clean (none of v2's) |" in text
    assert "learning beats the rule" in text


def test_a_tier_flown_only_by_references_has_no_ranking() -> None:
    matrices = {"planner": np.zeros((1, 60))}
    table = [_row("planner", "hard", matrices["planner"], privileged=True)]
    assert rank_suite(table, {"hard": matrices}) == {}


def test_each_tiers_comparison_of_recipes_for_the_student_is_linked() -> None:
    links = student_recipe_reports(["hard", "noisy"])
    assert links == {
        "hard": f"{STUDENT_RECIPES_DIR}/hard/ablation.md",
        "noisy": f"{STUDENT_RECIPES_DIR}/noisy/ablation.md",
    }
    text = suite_page(dataclasses.replace(_values([]), recipe_reports=links))
    assert "Recipes tried for the planner's flow student" in text
    assert "[`hard`](student_recipes/hard/ablation.md), [`noisy`](student_recipes/noisy/ablation.md)." in text
    assert "Recipes tried" not in suite_page(_values([]))


def test_the_camera_students_committed_recipe_pages_and_its_minutes_per_seed_are_linked() -> None:
    links = camera_student_recipe_reports()
    assert links["hard"] == "student_recipes_v2/hard/ablation.md"
    assert links["recipe_speed"] == "student_recipes_v2/recipe_speed/training_performance.md"
    text = suite_page(
        dataclasses.replace(_values([]), recipe_reports={"hard": "x.md"}, camera_recipe_reports=links)
    )
    assert "[`recipe_speed`](student_recipes_v2/recipe_speed/training_performance.md)" in text


def test_a_retired_agent_is_listed_with_its_seeds_failures_from_the_episodes_it_kept(tmp_path: Path) -> None:
    from helpers import EPISODE

    from agents.analysis.records import append_record
    from agents.pages.suite_page import retired_values
    from agents.policies import RETIRED_AGENTS

    retired = next(iter(RETIRED_AGENTS))
    path = tmp_path / "suite_episodes.csv"
    # Seed 0 flies both hard layouts (one failed), seed 1 only one of them: only whole seeds are reported.
    for seed, layout, success in ((0, 10, True), (0, 11, False), (1, 10, True)):
        record = dataclasses.replace(
            EPISODE,
            agent=f"{retired}@{seed}",
            factor="hard",
            seed=layout,
            success=success,
            collision=not success,
        )
        append_record(path, record)
    append_record(path, dataclasses.replace(EPISODE, factor="hard"))  # a suite agent: not reported here
    (found,) = [r for r in retired_values(path, layouts=[10, 11]) if r["agent"] == retired]
    assert found["why"] == RETIRED_AGENTS[retired]
    assert found["tiers"] == [{"tier": "hard", "failures": [0.5]}]
    assert all(r["tiers"] == [] for r in retired_values(tmp_path / "none.csv", layouts=[10, 11]))
    text = suite_page(dataclasses.replace(_values([]), retired=[found]))
    assert "### Retired from the suite" in text
    assert f"- `{retired}`: {RETIRED_AGENTS[retired]}. `hard`: 0.50." in text
    assert "Retired from the suite" not in suite_page(_values([]))


def test_the_agents_a_version_does_not_fly_are_listed_with_why() -> None:
    from agents.policies import NOT_FLOWN_ON

    text = suite_page(
        dataclasses.replace(_values([]), not_flown={"ppo_x": "a reference no chain needs"}, suite_version="2")
    )
    assert "### Not flown on suite v2" in text and "- `ppo_x`: a reference no chain needs." in text
    assert "### Not flown on suite" not in suite_page(dataclasses.replace(_values([]), not_flown={}))
    assert _values([]).not_flown == NOT_FLOWN_ON.get(SUITE_VERSION, {})
