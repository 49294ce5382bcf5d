"""Suite v2's tiers: a closed field, physics stated in code, the flight stack's correlated velocity error, new ids."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import flownav_env  # noqa: F401  (registers the ids)
from agents.common.seeds import SUITE_SEED_STARTS, SUITE_V2_CHECK_SEED_START, suite_seeds
from flownav_env.scene import field_layout
from flownav_env.sensor_errors import gauss_markov_step
from flownav_env.sensor_specs import VELOCITY_READINGS, flight_stack_sensor, translation_noise_m
from flownav_env.settings import EnvSettings
from flownav_env.tiers import (
    SUITE_VERSION,
    SUITE_VERSIONS,
    TIERS_BY_VERSION,
    check_suite_version,
    hard_course,
    tier,
    tier_of_env_id,
)


def test_v2_is_the_current_version_with_new_ids_and_v1_keeps_its_task() -> None:
    assert SUITE_VERSION == "2" == max(SUITE_VERSIONS) == max(SUITE_SEED_STARTS)
    assert [spec.env_id for spec in TIERS_BY_VERSION["2"].values()] == [
        "FlowNav-v1",
        "FlowNavHard-v1",
        "FlowNavNoisy-v1",
        "FlowNavHardNoisy-v1",
    ]
    for version, tiers in TIERS_BY_VERSION.items():
        for spec in tiers.values():
            assert tier_of_env_id(spec.env_id) == (version, spec)
            registered = gym.spec(spec.env_id).kwargs
            assert {key: registered[key] for key in spec.settings} == spec.settings
    assert "field_width" not in gym.spec("FlowNavHard-v0").kwargs  # v1's open field, unchanged


@pytest.mark.parametrize("name", list(TIERS_BY_VERSION["2"]))
def test_each_v2_tier_field_covers_its_bounds(name: str) -> None:
    settings = EnvSettings(**tier(name).settings)
    assert settings.field_width >= 2 * settings.lateral_bound
    # Drawn layouts have capsules right up to both bounds: no capsule-free lane beside the field.
    for seed in range(SUITE_V2_CHECK_SEED_START, SUITE_V2_CHECK_SEED_START + 5):
        capsules, _ = field_layout(np.random.default_rng(seed), settings.layout_params())
        assert capsules[:, 1].max() > settings.lateral_bound - 1.5
        assert capsules[:, 1].min() < -settings.lateral_bound + 1.5


def test_the_hard_course_follows_from_its_physics() -> None:
    course = hard_course(1.0)
    assert course["forward_speed"] == 2.0  # twice the distance per frame
    free_path = 1.0 / (course["obstacle_density"] * 2 * (0.5 + 0.2))
    assert free_path == pytest.approx(2.0 * course["forward_speed"], rel=0.02)  # 2 s of flight
    assert tier("hard").course["forward_speed"] == course["forward_speed"]


def test_the_flight_stack_sensor_reads_the_velocity_once_and_correlates_it() -> None:
    sensor = flight_stack_sensor()
    assert sensor["translation_noise_m"] == translation_noise_m(VELOCITY_READINGS["3d_speed"][1])
    assert sensor["translation_noise_correlation_s"] == 1.0
    assert tier("noisy").sensor == tier("hard_noisy").sensor == sensor
    assert tier("clean").sensor == {} == tier("hard").sensor


def test_bad_readings_and_versions_are_refused_in_one_line() -> None:
    with pytest.raises(ValueError, match="reading must be one of per_axis, 3d_speed, 2d_speed, got 'median'"):
        flight_stack_sensor(reading="median")
    with pytest.raises(ValueError, match=r"correlation_s must be > 0 s, got 0\.0"):
        flight_stack_sensor(correlation_s=0.0)
    with pytest.raises(ValueError, match="suite version must be one of 1, 2, got '3'"):
        check_suite_version("3")
    with pytest.raises(ValueError, match="suite version must be one of 1, 2, got '0'"):
        suite_seeds(10, "0")
    with pytest.raises(ValueError, match="translation_noise_correlation_s"):
        EnvSettings(translation_noise_correlation_s=-1.0)


def test_v2_test_layouts_are_a_new_frozen_range() -> None:
    v1, v2 = suite_seeds(300, "1"), suite_seeds(300, "2")
    assert not set(v1) & set(v2)
    assert suite_seeds(300) == v2


def test_the_gauss_markov_error_has_its_sigma_and_correlation() -> None:
    rng = np.random.default_rng(0)
    sigma, tau, interval = 0.003, 1.0, 0.1
    errors = [gauss_markov_step(None, sigma, tau, interval, rng)]
    for _ in range(20_000):
        errors.append(gauss_markov_step(errors[-1], sigma, tau, interval, rng))
    series = np.asarray(errors)[:, 0]
    assert series.std() == pytest.approx(sigma, rel=0.1)
    lag_one = np.corrcoef(series[:-1], series[1:])[0, 1]
    assert lag_one == pytest.approx(math.exp(-interval / tau), abs=0.02)


def test_the_correlated_error_changes_the_told_translation_only() -> None:
    """The noisy tier's told translation differs from the clean tier's by an error that persists frame to
    frame; the observation of the first frame (no motion yet) does not."""
    from flownav_env.sensor import SensorPipeline

    settings = EnvSettings(**tier("noisy").settings).sensor.__class__(
        translation_noise_m=0.01, translation_noise_correlation_s=1.0
    )
    pipeline = SensorPipeline(10.0)
    rng = np.random.default_rng(1)
    pose = (np.eye(3), np.zeros(3))
    pipeline.start(pose)
    told = []
    for k in range(1, 30):
        frame = pipeline.motion(settings, rng, (np.eye(3), np.array([0.0, 0.0, 0.1 * k])))
        told.append(frame.told_motion[1] - frame.true_motion[1])
    errors = np.asarray(told)
    assert np.abs(errors).max() > 0
    assert np.corrcoef(errors[:-1, 0], errors[1:, 0])[0, 1] > 0.5  # white noise would give about 0
