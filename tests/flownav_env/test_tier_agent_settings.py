"""What an agent may ask of a tier: observation keys only, privileged data only when declared, and episodes
recorded with other settings refused."""

from __future__ import annotations

import re

import gymnasium as gym
import pytest

import flownav_env  # noqa: F401  (registers the ids)
from flownav_env.settings import EnvSettings
from flownav_env.tiers import (
    AGENT_OBSERVATION_SETTINGS,
    TIER_NAMES,
    TIERS,
    check_agent_settings,
    check_flown_settings,
    privileged_requests,
    tier_value,
)


@pytest.mark.parametrize("name", TIER_NAMES)
def test_observation_keys_and_the_tiers_own_values_pass_on_every_tier(name: str) -> None:
    shaping = ("near_smoothing", "histogram_sectors", "depth_bin_edges")
    wanted = {setting: True for setting in AGENT_OBSERVATION_SETTINGS if setting not in shaping}
    check_agent_settings("mine", {**wanted, "near_smoothing": 0.5, "obs_source": "flow"}, name)
    check_agent_settings("mine", {"forward_speed": tier_value(name, "forward_speed")}, name)


@pytest.mark.parametrize("name", TIER_NAMES)
@pytest.mark.parametrize(
    ("setting", "value"), [("obstacle_density", 0.0), ("rotation_bias", 0.0), ("lateral_bound", 50.0)]
)
def test_any_other_setting_is_refused_on_every_tier(name: str, setting: str, value: float) -> None:
    if TIERS[name].settings.get(setting, getattr(EnvSettings(), setting)) == value:
        value = 0.01  # the tier flies this value already: ask for another
    fixed = tier_value(name, setting)
    with pytest.raises(
        ValueError,
        match=re.escape(
            f"agent mine asks for {setting}={value!r}, but tier {name} fixes {setting}={fixed!r}"
        ),
    ):
        check_agent_settings("mine", {setting: value}, name)


@pytest.mark.parametrize("source", ["oracle", "oracle_valid"])
def test_true_depths_only_for_an_agent_declared_privileged(source: str) -> None:
    assert privileged_requests({"obs_source": source, "observe_approach": True}) == {"obs_source": source}
    with pytest.raises(
        ValueError, match=re.escape(f"agent mine asks for obs_source={source!r}, privileged data")
    ):
        check_agent_settings("mine", {"obs_source": source}, "noisy")
    check_agent_settings("mine", {"obs_source": source}, "noisy", privileged=True)


def test_the_capsule_layout_only_for_an_agent_declared_privileged() -> None:
    assert privileged_requests({"observe_layout": True, "observe_counts": True}) == {"observe_layout": True}
    with pytest.raises(
        ValueError, match=re.escape("agent mine asks for observe_layout=True, privileged data")
    ):
        check_agent_settings("mine", {"observe_layout": True}, "hard")
    check_agent_settings("mine", {"observe_layout": True}, "hard", privileged=True)
    check_agent_settings("mine", {"observe_layout": False}, "hard")


def test_the_tier_fixes_the_defaults_it_does_not_name() -> None:
    assert tier_value("noisy", "obstacle_density") == EnvSettings().obstacle_density
    assert tier_value("hard", "obstacle_density") == TIERS["hard"].settings["obstacle_density"]
    with pytest.raises(ValueError, match="'no_such' is not a FlowNav env setting"):
        tier_value("clean", "no_such")


def test_flown_settings_must_hold_the_tiers_and_nothing_an_agent_may_not_choose() -> None:
    hard = dict(TIERS["hard"].settings)
    check_flown_settings("mine", {**hard, "observe_unresolved": True}, "hard")
    with pytest.raises(
        ValueError, match=re.escape("agent mine was flown on tier hard with forward_speed=1.0")
    ):
        check_flown_settings("mine", {**hard, "forward_speed": 1.0}, "hard")
    with pytest.raises(ValueError, match=re.escape("with obstacle_density='the default'")):
        check_flown_settings("mine", {k: v for k, v in hard.items() if k != "obstacle_density"}, "hard")
    with pytest.raises(ValueError, match=re.escape("asks for max_height=9.0, but tier hard fixes")):
        check_flown_settings("mine", {**hard, "max_height": 9.0}, "hard")


def test_an_agent_may_ask_for_a_finer_histogram_on_any_tier() -> None:
    """The histogram's resolution is an observation setting: the same depths binned finer, the task unchanged."""
    finer = {"histogram_sectors": (3, 15), "depth_bin_edges": (0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 5.0, 8.0, 13.0)}
    for name in TIERS:
        check_agent_settings("fine", finer, name)
        check_flown_settings("fine", {**TIERS[name].settings, **finer}, name)
    env = gym.make(TIERS["hard"].env_id, camera_width=64, camera_height=48, **finer)
    try:
        observation, _ = env.reset(seed=0)
    finally:
        env.close()
    assert observation["depth_histogram"].shape == (3, 15, 8)
