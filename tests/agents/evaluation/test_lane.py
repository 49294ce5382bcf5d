"""The capsule-free lane: its edge per tier, the count of episodes past it per agent and tier from flights that
record how far sideways they went, and suite.md's section in both verdicts; and, for any suite version, how far
sideways each tier's successes went against its field's edge."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import pytest
from helpers import EPISODE

from agents.analysis.records import append_record
from agents.evaluation.lane import lane_edge, lane_values, sideways_extent
from agents.pages.suite_page import beside_suite, suite_page, suite_values
from flownav_env.tiers import TIERS, tier_value

RECORD = replace(
    EPISODE,
    agent="bee_ttc",
    seed=960_200,
    collision=False,
    success=True,
    env_id="FlowNav-v0",
    env_kwargs="",
    max_abs_lateral_m=1.0,
)


def _page(lanes: list, sideways: list | None = None) -> str:
    """suite.md with no agent flown, the lane rows ``lanes`` and the ``sideways`` rows beside it."""
    return suite_page(
        suite_values(
            [],
            {},
            command="c",
            layouts=range(1),
            machine="m",
            missing=[],
            generated="today",
            lanes=lanes,
            sideways=sideways or [],
        )
    )


@pytest.mark.parametrize("name", sorted(TIERS))
def test_the_lane_starts_past_every_capsule_surface_and_inside_the_bounds(name: str) -> None:
    edge = float(tier_value(name, "field_width", "1")) / 2 + float(tier_value(name, "obstacle_radius", "1"))
    assert lane_edge(name) == pytest.approx(edge)
    assert lane_edge(name) < float(tier_value(name, "lateral_bound", "1"))


def test_episodes_past_the_edge_are_counted_per_agent_and_tier(tmp_path: Path) -> None:
    folder = tmp_path / "lane"
    folder.mkdir()
    clean, hard = folder / "bee_ttc_clean.csv", folder / "bee_ttc_hard.csv"
    append_record(clean, RECORD)
    append_record(clean, replace(RECORD, seed=960_201, max_abs_lateral_m=lane_edge("clean") + 0.1))
    append_record(clean, replace(RECORD, seed=960_202, max_abs_lateral_m=math.nan))  # not recorded
    append_record(hard, replace(RECORD, env_id="FlowNavHard-v0", max_abs_lateral_m=2.0))
    append_record(folder / "other.csv", replace(RECORD, env_id="FlowNavSingle-v0", max_abs_lateral_m=9.0))
    rows = lane_values(folder)
    assert [(r["agent"], r["tier"], r["episodes"], r["entered"]) for r in rows] == [
        ("bee_ttc", "clean", 2, 1),
        ("bee_ttc", "hard", 1, 0),
    ]
    assert rows[0]["widest"] == pytest.approx(lane_edge("clean") + 0.1) and rows[1]["bound"] == 6.0
    assert lane_values(tmp_path / "none") == []


def test_the_suite_page_says_whether_any_agent_entered_the_lane(tmp_path: Path) -> None:
    folder = tmp_path / "lane"
    append_record(folder / "bee_ttc_clean.csv", RECORD)
    beside = beside_suite(tmp_path, ["clean"], tmp_path / "suite_episodes.csv", [])
    text = _page(beside["lanes"])
    assert "## The capsule-free lane" in text and "| agent | `clean` (lane 4.5–6.0 m) |" in text
    assert "| `bee_ttc` | 0 of 1 (1.00 m) |" in text
    assert "No agent entered the lane on any tier" in text
    append_record(folder / "bee_ttc_clean.csv", replace(RECORD, seed=960_201, max_abs_lateral_m=5.0))
    text = _page(beside_suite(tmp_path, ["clean"], tmp_path / "suite_episodes.csv", [])["lanes"])
    assert "| `bee_ttc` | 1 of 2 (5.00 m) |" in text
    assert "1 of 1 agents entered the lane on at least one tier. An agent there flies past capsules" in text
    assert "## The capsule-free lane" not in _page([])


def _tiered(tier: str, success: bool, extent: float) -> dict:
    return {"tier": tier, "success": success, "max_abs_lateral_m": extent}


def test_successes_past_the_field_edge_are_counted_per_tier_of_the_version() -> None:
    rows = [
        _tiered("hard", True, 5.5),
        _tiered("clean", True, 3.0),
        _tiered("clean", True, 4.6),  # past v1's edge (4 m), inside v2's (6 m)
        _tiered("clean", False, 7.0),  # a failure: out of bounds is not a success's extent
        _tiered("clean", True, math.nan),  # not recorded
        {"tier": "clean", "success": True, "max_abs_lateral_m": None},  # predates the column
    ]
    v2 = sideways_extent(rows, "2")
    assert [(r["tier"], r["successes"], r["near_edge"], r["past_field"], r["widest"]) for r in v2] == [
        ("clean", 2, 0, 0, 4.6),
        ("hard", 1, 1, 0, 5.5),  # within NEAR_EDGE_M of v2's edge
    ]
    assert v2[0]["field_edge"] == 6.0 and v2[0]["bound"] == 6.0
    v1 = sideways_extent(rows, "1")
    assert [(r["tier"], r["past_field"]) for r in v1] == [("clean", 1), ("hard", 1)]
    assert v1[0]["field_edge"] == 4.0
    assert sideways_extent([], "2") == []


def test_the_suite_page_says_whether_any_success_went_past_the_field() -> None:
    closed = sideways_extent([_tiered("clean", True, 5.9)], "2")
    text = _page([], closed)
    assert "| `clean` | 1 | 5.900 | 6.0 | 6.0 | 1 (1.00) | 0 |" in text
    assert "No success on any tier went past the field's edge." in text
    text = _page([], sideways_extent([_tiered("clean", True, 5.9), _tiered("hard", True, 4.5)], "1"))
    assert "2 successes went past the field's edge: this field leaves a lane." in text
    assert "How far sideways the successes went" not in _page([])
