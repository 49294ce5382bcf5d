"""Which tiers a training config covers."""

from __future__ import annotations

from pathlib import Path

import pytest

from agents.common.locations import CONFIGS_DIR
from agents.policies.trained_tiers import config_tiers, tiers_covered
from flownav_env.sensor_specs import realistic_sensor
from flownav_env.tiers import HARD_COURSE, TIER_NAMES


def test_the_env_defaults_are_the_clean_tier_only():
    assert tiers_covered({}, {}, "1") == ("clean",)


def test_a_fixed_hard_course_is_the_hard_tier():
    assert tiers_covered(dict(HARD_COURSE), {}, "1") == ("hard",)


def test_ranges_spanning_every_course_and_sensor_cover_every_tier():
    ranges = {"forward_speed": (1.0, 2.0), "obstacle_density": (0.12, 0.18)}
    ranges |= {key: (0.0, value) for key, value in realistic_sensor().items()}
    assert tiers_covered({}, ranges, "1") == TIER_NAMES


def test_a_range_short_of_a_tier_value_leaves_that_tier_out():
    assert tiers_covered({}, {"forward_speed": (0.5, 1.5)}, "1") == ("clean",)


def test_observation_settings_do_not_change_the_task():
    assert tiers_covered({"obs_source": "oracle", "observe_approach": True}, {}, "1") == ("clean",)


def test_an_unknown_setting_is_refused_in_one_line():
    with pytest.raises(
        ValueError, match=r"not FlowNav env settings: wind_speed; settings are .*forward_speed"
    ):
        tiers_covered({"wind_speed": 3.0}, {})


def test_the_planner_student_trains_across_every_tier_and_ppo_flow_on_clean():
    assert config_tiers(CONFIGS_DIR / "experiments" / "ppo_flow_planner_student.yaml", "1") == TIER_NAMES
    assert config_tiers(CONFIGS_DIR / "ppo_flow.yaml", "1") == ("clean",)


def test_v1_trained_agents_cover_no_tier_of_the_closed_field():
    """An agent trained on v1's open field trained on none of v2's tiers (their field is closed)."""
    assert config_tiers(CONFIGS_DIR / "ppo_flow.yaml") == ()
    assert config_tiers(CONFIGS_DIR / "experiments" / "ppo_flow_planner_student.yaml") == ()
    assert tiers_covered({"field_width": 12.0}, {}) == ("clean",)


def test_an_env_id_outside_the_tiers_covers_none(tmp_path: Path):
    text = (
        (CONFIGS_DIR / "ppo_flow.yaml")
        .read_text()
        .replace("env_id: FlowNav-v0", "env_id: FlowNavPlayback-v0")
    )
    assert "FlowNavPlayback-v0" in text
    path = tmp_path / "other.yaml"
    path.write_text(text)
    assert config_tiers(path) == ()
