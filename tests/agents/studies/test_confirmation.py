"""Confirming a pick on fresh layouts: the paired comparison, the search record and the report's wording."""

from __future__ import annotations

import numpy as np
import pytest

from agents.analysis.validation_rows import (
    ConditionRate,
    ConfirmationResult,
    PairedDifference,
    Rise,
    SearchRecord,
)
from agents.common.locations import RESULTS_DIR
from agents.studies.confirmation import (
    COMPARED,
    PICK,
    SEARCH_RUNS,
    TRUE_DEPTH_RECIPE,
    agent_runs,
    confirmation_tasks,
    flow_costs,
    flown_agents,
    paired_difference,
    report_lines,
    search_record,
)


def test_pairing_by_layout_narrows_a_difference_the_layouts_share() -> None:
    rng = np.random.default_rng(0)
    hard = rng.random(200) < 0.3  # layouts both agents fail on
    first = np.tile(hard, (5, 1)).astype(float)
    second = first.copy()
    second[:, :10] = 1.0  # the second fails ten more layouts
    value, low, high = paired_difference(first, second)
    assert value == pytest.approx(-(10 - hard[:10].sum()) / 200)
    assert low <= value <= high < 0 and high - low < 0.06


def test_tasks_fly_every_run_on_every_layout_under_every_condition(tmp_path) -> None:
    tasks = confirmation_tasks(
        {"ppo_flow@0": tmp_path / "a.zip", "ppo_flow@1": tmp_path / "b.zip"}, layouts=2
    )
    assert len(tasks) == 3 * 2 * 2
    assert {(t.factor, t.level) for t in tasks} == {
        ("clean", 0.0),
        ("obstacle_density", 0.18),
        ("forward_speed", 1.5),
    }
    assert min(t.seed for t in tasks) == 910_000


def test_the_search_record_reads_the_committed_ablation() -> None:
    record = search_record(RESULTS_DIR / "ablation")
    assert PICK in record.configs and len(record.layouts) >= 50
    assert all(900_000 <= seed < 910_000 for seed in record.layouts)


def test_the_report_words_each_comparison_from_its_interval() -> None:
    result = ConfirmationResult(
        layouts=200,
        rates=[ConditionRate("clean", PICK, 5, 0.04, 0.02, 0.07)],
        differences=[
            PairedDifference("clean", "ppo_flow", -0.05, -0.08, -0.02),
            PairedDifference("density 0.18", "ppo_flow_course_approach", -0.02, -0.06, 0.03),
        ],
        rises=[
            Rise("density 0.18", PICK, 0.04, 0.01, 0.08),
            Rise("speed 1.5 m/s", PICK, 0.06, 0.01, 0.12),
            Rise("speed 1.5 m/s", "ppo_flow", 0.3, 0.2, 0.4),
        ],
    )
    text = "\n".join(
        report_lines(result, SearchRecord(["a", "b"], [900_000, 900_049], []), "flownav confirm")
    )
    assert "| fails less |" in text and "| no difference shown |" in text
    assert "met, interval included" in text and "met by point estimate only" in text and "| not met |" in text
    assert "flew 2 PPO configurations" in text
    assert "0.040 [0.020, 0.070]" in text
    assert f"`{TRUE_DEPTH_RECIPE}`, has no shipped training seeds yet" in text
    empty = ConfirmationResult(layouts=200, rates=[], differences=[], rises=[])
    assert "Not flown yet" in "\n".join(report_lines(empty, SearchRecord([], [], []), "x"))


def test_the_true_depth_recipe_flies_once_it_has_shipped_seeds(tmp_path) -> None:
    assert flown_agents(tmp_path) == (PICK, *COMPARED)
    (tmp_path / TRUE_DEPTH_RECIPE).mkdir()
    (tmp_path / TRUE_DEPTH_RECIPE / "seed_0.zip").write_bytes(b"")
    assert flown_agents(tmp_path) == (PICK, *COMPARED, TRUE_DEPTH_RECIPE)


def test_flow_costs_are_the_pick_against_its_true_depth_recipe() -> None:
    against_truth = PairedDifference("clean", TRUE_DEPTH_RECIPE, 0.02, -0.01, 0.05)
    against_flow = PairedDifference("clean", "ppo_flow", -0.05, -0.08, -0.02)
    result = ConfirmationResult(layouts=200, rates=[], differences=[against_flow, against_truth], rises=[])
    assert flow_costs(result) == [against_truth]


def test_the_confirmation_flies_the_runs_the_search_compared_not_seeds_shipped_later(tmp_path) -> None:
    folder = tmp_path / "ppo_flow"
    folder.mkdir()
    for seed in range(SEARCH_RUNS + 3):
        (folder / f"seed_{seed}.zip").write_bytes(b"")
    runs = agent_runs("ppo_flow", tmp_path)
    assert list(runs) == [f"ppo_flow@{seed}" for seed in range(SEARCH_RUNS)]
    assert runs["ppo_flow@0"] == folder / "seed_0.zip"
