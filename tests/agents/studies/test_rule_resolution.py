"""The flow rules at finer depth histograms: tasks, pairing, the pick, its confirmation, resuming."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from agents.analysis.episode_record import EpisodeRecord
from agents.analysis.records import read_records
from agents.common.seeds import (
    RULE_RESOLUTION_CONFIRM_SEED_START,
    RULE_RESOLUTION_REFINE_SEED_START,
    RULE_RESOLUTION_SEED_START,
)
from agents.evaluation import runner
from agents.evaluation.episode_tasks import EpisodeTask
from agents.policies.histogram_resolution import FINE_BIN_EDGES
from agents.studies.rule_resolution import (
    CANDIDATES,
    REFINE_CANDIDATES,
    REFINE_RULE,
    RULES,
    TIERS,
    TODAY,
    layout_seeds,
    pick,
    resolution_named,
    resolution_tasks,
    run_rule_resolution,
)

FINE = "3x15-9bins"


def _fake_flight(
    monkeypatch: pytest.MonkeyPatch, flown: list[EpisodeTask], fine_from: int = RULE_RESOLUTION_SEED_START
) -> None:
    """Episodes without MuJoCo: ``bee_ttc`` at the finer bins reaches the goal on every layout from ``fine_from``,
    every other configuration (and it before) on the even layouts only; the records carry the task's identity as
    the runner's do."""

    def run_task(task: EpisodeTask, cache: object = None) -> EpisodeRecord:
        flown.append(task)
        fine = task.agent == "bee_ttc" and task.factor.endswith(FINE) and task.seed >= fine_from
        success = fine or task.seed % 2 == 0
        record = EpisodeRecord(
            task.agent, task.factor, task.level, task.seed, not success, success, False, False,
            10.0, 1.0, 10, 0.5, 10.0, 100.0, 0.1, 1.0,
        )  # fmt: skip
        return dataclasses.replace(record, **task.identity(), code_version="test")

    monkeypatch.setattr(runner, "run_task", run_task)


def test_tasks_fly_each_tier_with_the_resolution_asked_and_matching_bins() -> None:
    fine = resolution_named(FINE)
    tasks = resolution_tasks("bee_ttc", fine, layout_seeds("search", 2))
    assert [(t.factor, t.seed) for t in tasks] == [
        (f"{name}/{FINE}", RULE_RESOLUTION_SEED_START + i) for name in TIERS for i in range(2)
    ]
    assert {t.env_id for t in tasks} == {"FlowNavHard-v1", "FlowNavHardNoisy-v1"}
    settings = tasks[0].env_settings()
    assert settings["histogram_sectors"] == (3, 15) and settings["depth_bin_edges"] == FINE_BIN_EDGES
    assert settings["observe_unresolved"] is True  # what the rule reads beyond the defaults, kept
    assert json.loads(tasks[0].identity()["agent_params"])["bin_edges"] == list(FINE_BIN_EDGES)
    # The rule's own resolution asks the env for nothing new: the episodes are the rule's as the suite flies it.
    own = resolution_tasks("bee_ttc", TODAY, layout_seeds("search", 1))[0]
    assert own.env_settings() == {"observe_unresolved": True} and own.bee_params == ()
    assert [r.name for r in (TODAY, *CANDIDATES)] == ["3x5", "3x10", "3x15", FINE]


def test_the_refinement_flies_its_rule_at_the_student_bins_on_fresh_layouts_and_its_pick_is_confirmed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    flown: list[EpisodeTask] = []
    _fake_flight(monkeypatch, flown)
    result = run_rule_resolution(tmp_path, search_layouts=8, refine_layouts=10, confirm_layouts=6)
    search = len(RULES) * (1 + len(CANDIDATES)) * len(TIERS) * 8
    refinement = (1 + len(REFINE_CANDIDATES)) * len(TIERS) * 10
    assert (
        len(flown) == search + refinement + 2 * len(TIERS) * 6
    )  # the pick and the rule's own, fresh layouts
    assert {t.agent for t in flown[search : search + refinement]} == {REFINE_RULE}
    assert min(t.seed for t in flown[search : search + refinement]) == RULE_RESOLUTION_REFINE_SEED_START
    assert result.picks == {"bee_robust": None, "bee_ttc": FINE, "vfh": None}
    assert result.refined == FINE and result.chosen == result.picks
    assert result.confirmed == {"bee_robust": None, "bee_ttc": True, "vfh": None}
    # The search's 12 and one resolution new in the refinement (the student's bins at 3x5).
    assert result.configurations_tried == 13 and not result.missing
    refining = [row for row in result.rows if row.stage == "refinement"]
    assert [row.resolution for row in refining] == ["3x5", FINE, "3x5-9bins"]
    assert refining[2].versus_today is not None and refining[2].versus_today.difference == 0.0
    assert refining[1].episodes == 20 and refining[1].failure == 0.0
    confirming = [row for row in result.rows if row.stage == "confirmation"]
    assert [(row.rule, row.resolution) for row in confirming] == [("bee_ttc", "3x5"), ("bee_ttc", FINE)]
    row = confirming[-1]
    assert row.failure == 0.0 and row.per_tier == {"hard": 0.0, "hard_noisy": 0.0} and row.episodes == 12
    assert row.versus_today is not None and row.versus_today.difference == pytest.approx(-0.5)
    assert min(t.seed for t in flown[search + refinement :]) == RULE_RESOLUTION_CONFIRM_SEED_START
    # Resumed: nothing is flown again, and the report reads the same episodes.
    flown.clear()
    again = run_rule_resolution(tmp_path, search_layouts=8, refine_layouts=10, confirm_layouts=6)
    assert flown == [] and again.rows == result.rows
    assert len(read_records(tmp_path / "episodes.csv")) == search + refinement + 24


def test_the_refinement_pick_is_confirmed_even_where_the_search_picked_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    flown: list[EpisodeTask] = []
    # The finer bins help only from the refinement's layouts on: in the search every configuration ties.
    _fake_flight(monkeypatch, flown, fine_from=RULE_RESOLUTION_CONFIRM_SEED_START)
    result = run_rule_resolution(tmp_path, search_layouts=4, refine_layouts=10, confirm_layouts=6)
    assert set(result.picks.values()) == {None} and result.refined == FINE
    assert result.chosen == {"bee_robust": None, "bee_ttc": FINE, "vfh": None}
    assert result.confirmed["bee_ttc"] is True


def test_a_short_search_picks_nothing_and_lists_what_is_missing(tmp_path: Path) -> None:
    result = run_rule_resolution(tmp_path, search_layouts=3, report_only=True)
    assert result.rows == [] and set(result.picks.values()) == {None}
    assert "bee_robust at 3x5 (search)" in result.missing and len(result.missing) == 12 + 3
    assert "bee_ttc at 3x5-9bins (refinement)" in result.missing and result.refined is None


def test_pick_takes_the_largest_drop_among_intervals_below_zero() -> None:
    rng = np.random.default_rng(0)
    from agents.studies.rule_resolution import _row

    today = (rng.random((1, 40)) < 0.6).astype(float)
    better = today.copy()
    better[0, :20] = 0.0
    slightly = today.copy()
    slightly[0, :3] = 0.0
    rows = [
        _row("search", "vfh", CANDIDATES[0], slightly, today),
        _row("search", "vfh", CANDIDATES[2], better, today),
        _row("search", "vfh", CANDIDATES[1], today, today),
    ]
    assert rows[1].versus_today is not None and rows[1].versus_today.high < 0
    assert pick(rows) == FINE
    assert pick(rows[::2]) is None  # a small drop whose interval holds 0, and no change


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: layout_seeds("search", 0), r"search layouts must be an integer in \[1, 1000\], got 0"),
        (lambda: layout_seeds("confirmation", 1001), r"confirmation layouts must be .*\[1, 1000\], got 1001"),
        (lambda: layout_seeds("search", True), r"search layouts must be an integer in \[1, 1000\], got True"),
        (lambda: layout_seeds("refinement", -1), r"refinement layouts must be .*\[1, 1000\], got -1"),
        (
            lambda: layout_seeds("test", 5),
            "stage must be one of search, refinement, confirmation, got 'test'",
        ),
        (
            lambda: resolution_named("3x7"),
            "resolution must be one of 3x5, 3x10, 3x15, 3x15-9bins, 3x5-9bins, got '3x7'",
        ),
        (
            lambda: resolution_tasks("bee", TODAY, range(1)),
            "rule must be one of bee_robust, bee_ttc, vfh, got 'bee'",
        ),
    ],
)
def test_bad_inputs_are_one_line_naming_the_value_and_the_allowed_ones(call, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        call()
