"""Suite v2's check flights and their calibration page: the feasibility checks per tier and reference, and the
sensitivity table paired by layout, from episode files laid out as the flights write them."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest
from helpers import EPISODE

from agents.analysis.records import append_record
from agents.evaluation.suite_check_flights import (
    FEASIBLE_FAILURE,
    SENSITIVITY_DIR,
    check_rows,
    passing,
    sensitivity_file,
    sensitivity_rows,
)
from agents.evaluation.suite_checks import frozen_physics
from agents.pages.calibration_page import write_page

SUCCESS = replace(EPISODE, agent="planner", collision=False, success=True, max_abs_lateral_m=4.2)


def _fly(path: Path, seeds: range, failed: set[int], **fields: object) -> None:
    for seed in seeds:
        record = replace(SUCCESS, seed=seed, **fields)
        if seed in failed:
            record = replace(record, success=False, collision=True)
        append_record(path, record)


def test_each_reference_passes_a_tier_only_at_or_under_the_feasible_failure(tmp_path: Path) -> None:
    _fly(tmp_path / "planner_FlowNav-v1.csv", range(970_000, 970_050), set(), env_id="FlowNav-v1")
    _fly(
        tmp_path / "planner_FlowNavHard-v1.csv",
        range(970_000, 970_050),
        {970_003, 970_004},
        env_id="FlowNavHard-v1",
    )
    rows = {(row["tier"], row["agent"]): row for row in check_rows(tmp_path, frozen_physics().tiers)}
    clean, hard = rows[("clean", "planner")], rows[("hard", "planner")]
    assert (clean["layouts"], clean["failure"], clean["passes"]) == (50, 0.0, True)
    assert (
        hard["failure"] == pytest.approx(0.04) and hard["failure"] > FEASIBLE_FAILURE and not hard["passes"]
    )
    assert clean["widest_m"] == pytest.approx(4.2) and clean["first_seed"] == 970_000
    assert rows[("noisy", "planner")]["layouts"] == 0  # not yet flown, listed as such
    assert not passing(list(rows.values()))


def test_the_sensitivity_table_pairs_other_readings_with_the_frozen_one_by_layout(tmp_path: Path) -> None:
    folder = tmp_path / SENSITIVITY_DIR
    folder.mkdir()
    frozen = folder / sensitivity_file("bee_ttc", "FlowNavNoisy-v1", "3d_speed", 1.0)
    other = folder / sensitivity_file("bee_ttc", "FlowNavNoisy-v1", "per_axis", 1.0)
    assert other.name == "bee_ttc_FlowNavNoisy-v1_per_axis_tau1.csv"
    _fly(frozen, range(971_000, 971_010), {971_000}, agent="bee_ttc")
    _fly(other, range(971_000, 971_012), {971_000, 971_001, 971_002}, agent="bee_ttc")
    (row,) = sensitivity_rows(tmp_path, frozen_physics())
    assert (row["agent"], row["env_id"], row["tau"], row["layouts"]) == (
        "bee_ttc",
        "FlowNavNoisy-v1",
        1.0,
        10,
    )
    assert row["frozen_failure"] == pytest.approx(0.1) and row["failure"] == pytest.approx(0.3)
    assert row["comparison"].difference == pytest.approx(0.2)


def test_the_page_states_the_physics_and_lists_what_is_not_flown(tmp_path: Path) -> None:
    _fly(tmp_path / "planner_FlowNav-v1.csv", range(970_000, 970_020), set(), env_id="FlowNav-v1")
    text = "\n".join(write_page(tmp_path, "cmd", frozen_physics()))
    assert (tmp_path / "calibration.md").read_text().strip() == text.strip()
    assert "n = 0.18 capsules/m²" in text and "τ = 1 s" in text and "12 m wide" in text
    assert "| `clean` | `FlowNav-v1` | `planner` | 20 | 0.00" in text
    assert "| `hard` | `FlowNavHard-v1` | `planner` | not yet flown |" in text
