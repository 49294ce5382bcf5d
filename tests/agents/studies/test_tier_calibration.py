"""The tiers' calibration (agents/studies/tier_calibration.py) against its committed episodes."""

from __future__ import annotations

from agents.analysis.records import read_records
from agents.common.locations import RESULTS_DIR
from agents.policies import AGENT_NAMES
from agents.policies.base import base_agent_name
from agents.studies.tier_calibration import (
    COURSE_AGENTS,
    EPISODES_CSV,
    TIER_AGENTS,
    course_label,
    report_lines,
    separated_pairs,
)

CALIBRATION = RESULTS_DIR / "suite_v1" / "suite_calibration" / EPISODES_CSV


def test_the_calibration_agents_are_those_that_flew_the_frozen_calibration() -> None:
    rows = read_records(CALIBRATION)
    tier_flyers = {base_agent_name(r["agent"]) for r in rows if r["factor"].startswith("tier:")}
    course_flyers = {base_agent_name(r["agent"]) for r in rows if not r["factor"].startswith("tier:")}
    assert tier_flyers == set(TIER_AGENTS)
    assert course_flyers == set(COURSE_AGENTS)
    # An agent added after suite version 1 was frozen is scored by `flownav suite`, never flown into it.
    assert set(TIER_AGENTS) <= set(AGENT_NAMES) and "straight" not in TIER_AGENTS


def test_a_course_label_names_its_settings_in_a_fixed_order() -> None:
    assert course_label({"obstacle_density": 0.18, "forward_speed": 2.0}) == (
        "forward_speed=2.0,obstacle_density=0.18"
    )


def test_agents_are_told_apart_by_a_paired_test_on_the_layouts_both_flew() -> None:
    def flown(agent: str, failed: int) -> list[dict]:
        return [{"agent": agent, "seed": seed, "success": seed >= failed} for seed in range(100)]

    # bee_ttc fails 30 more layouts than bee_robust; vfh fails two more than bee_ttc: too few to tell apart.
    episodes = flown("bee_robust", 10) + flown("bee_ttc", 40) + flown("vfh", 42)
    assert separated_pairs(episodes) == (2, 3)


def test_the_report_says_when_no_course_is_picked_and_nothing_was_piloted() -> None:
    empty = {"layouts": 100, "table": [], "pilot": [], "pilot_settings": {}, "chosen": None}
    text = "\n".join(
        report_lines({**empty, "best_per_course": {}, "frozen_matches": False, "tiers": {}}, "x")
    )
    assert "No candidate's best agent fails in [0.20, 0.50]: no pick." in text
    assert "| 1.5 | 0.12 | – | – | – | not flown |" in text and "{{" not in text
