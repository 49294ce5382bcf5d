"""The suite's tiers: registered ids that pass Gymnasium's and stable-baselines3's checkers, with the settings
and specification-derived sensor errors their docstring states."""

from __future__ import annotations

import math
import re

import gymnasium as gym
import pytest

import flownav_env
from flownav_env.sensor_specs import (
    CAMERA_IMU_OFFSET_MS,
    GYRO_NOISE_DENSITY_DEG_S_RTHZ,
    VELOCITY_ACCURACY_M_S,
    realistic_sensor,
)
from flownav_env.settings import EnvSettings
from flownav_env.tiers import (
    HARD_COURSE,
    SUITE_VERSION,
    TIER_NAMES,
    TIERS,
    TIERS_BY_VERSION,
    tier,
)


@pytest.mark.parametrize("name", TIER_NAMES)
def test_every_tier_passes_gymnasium_and_sb3_env_checkers(name: str) -> None:
    from gymnasium.utils.env_checker import check_env as gymnasium_check
    from stable_baselines3.common.env_checker import check_env as sb3_check

    env = gym.make(TIERS[name].env_id)
    try:
        gymnasium_check(env.unwrapped, skip_render_check=True)
        sb3_check(env.unwrapped, warn=True)
    finally:
        env.close()


@pytest.mark.parametrize("version", list(TIERS_BY_VERSION))
def test_each_tier_flies_the_settings_it_states(version: str) -> None:
    tiers = TIERS_BY_VERSION[version]
    assert TIER_NAMES == tuple(tiers) and TIER_NAMES[0] == "clean"
    for spec in tiers.values():
        env = gym.make(spec.env_id)
        settings = env.unwrapped.settings
        env.close()
        for key, value in spec.settings.items():
            assert getattr(settings, key) == value, (spec.name, key)
        assert spec.env_id in flownav_env.ENV_IDS and spec.why
    assert tiers["hard"].course == tiers["hard_noisy"].course
    assert tiers["noisy"].sensor == tiers["hard_noisy"].sensor


def test_v1_keeps_its_task() -> None:
    v1 = TIERS_BY_VERSION["1"]
    assert v1["clean"].env_id == "FlowNav-v0" and not v1["clean"].settings
    assert v1["hard"].course == HARD_COURSE == v1["hard_noisy"].course
    assert v1["noisy"].sensor == v1["hard_noisy"].sensor == realistic_sensor()


def test_the_realistic_sensor_is_its_specifications_per_frame() -> None:
    at_10_hz, at_20_hz = realistic_sensor(10.0), realistic_sensor(20.0)
    assert at_10_hz["rotation_noise_deg"] == pytest.approx(
        GYRO_NOISE_DENSITY_DEG_S_RTHZ * math.sqrt(0.1), abs=1e-6
    )
    assert at_10_hz["translation_noise_m"] == pytest.approx(2 * at_20_hz["translation_noise_m"], abs=2e-6)
    assert at_10_hz["translation_noise_m"] == pytest.approx(VELOCITY_ACCURACY_M_S / 0.6745 * 0.1, abs=1e-6)
    assert at_10_hz["imu_time_offset_ms"] == CAMERA_IMU_OFFSET_MS
    assert at_20_hz["rotation_noise_deg"] < at_10_hz["rotation_noise_deg"]
    EnvSettings(**at_10_hz)  # inside every setting's range


def test_an_unknown_tier_is_one_line_naming_the_tiers() -> None:
    with pytest.raises(
        ValueError, match=re.escape("tier must be one of clean, hard, noisy, hard_noisy, got 'easy'")
    ):
        tier("easy")


def test_the_suite_version_is_a_plain_string() -> None:
    assert isinstance(SUITE_VERSION, str) and SUITE_VERSION.isdigit()
