"""flownav_env.sensor_errors: each sensor error model does what its setting says, on arrays, with a seeded generator;
at zero it draws nothing and returns its inputs unchanged."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from estimator import DEFAULT_BIN_EDGES
from flownav_env.rotations import rotation_from_vector, vector_from_rotation
from flownav_env.sensor_errors import (
    add_motion_noise,
    corrupt_depths,
    lagged_attitude,
    outlier_depth_range,
    scale_motion,
    walk_bias,
)

ROTATION_VECTOR = np.array([0.02, -0.05, 0.01])


def _binomial_ok(count: int, trials: int, probability: float) -> bool:
    """``count`` successes of ``trials`` within 4.5 standard deviations of ``probability`` (a false alarm
    about once in 150,000 runs; the seeds are fixed anyway)."""
    spread = math.sqrt(trials * probability * (1.0 - probability))
    return abs(count - trials * probability) <= 4.5 * spread


def test_every_model_at_zero_draws_nothing_and_returns_its_inputs() -> None:
    rng = np.random.default_rng(0)
    state = rng.bit_generator.state
    rotation, translation = rotation_from_vector(ROTATION_VECTOR), np.array([0.1, 0.0, 0.5])
    scaled = scale_motion(rotation, translation, 1.0, 1.0)
    noisy = add_motion_noise(rotation, translation, 0.0, 0.0, rng)
    assert scaled[0] is rotation and scaled[1] is translation
    assert noisy[0] is rotation and noisy[1] is translation
    assert walk_bias(0.25, 0.0, 0.1, rng) == 0.25
    depths = np.array([1.0, 2.5, 7.0])
    corrupted, keep = corrupt_depths(depths, 0.0, 0.0, 0.0, 0.5, 13.0, rng)
    assert corrupted is depths and keep.dtype == bool and keep.all() and len(keep) == 3
    assert rng.bit_generator.state == state


def test_a_bias_scales_the_rotation_angle_and_the_translation_by_one_plus_b() -> None:
    rotation, translation = rotation_from_vector(ROTATION_VECTOR), np.array([0.1, -0.02, 0.5])
    for bias in (-0.9, -0.3, 0.2, 0.9):
        told_rotation, told_translation = scale_motion(rotation, translation, 1.0 + bias, 1.0 - bias)
        told = vector_from_rotation(told_rotation)
        angle = np.linalg.norm(ROTATION_VECTOR)
        assert np.linalg.norm(told) == pytest.approx((1.0 + bias) * angle, rel=1e-12)
        np.testing.assert_allclose(told / np.linalg.norm(told), ROTATION_VECTOR / angle, atol=1e-12)  # axis
        np.testing.assert_array_equal(told_translation, translation * (1.0 - bias))


def test_drift_spreads_like_the_square_root_of_time() -> None:
    rng, drift, interval, walks = np.random.default_rng(1), 0.3, 0.1, 4000
    walk = np.zeros(walks)
    spread = {}
    for frame in range(1, 41):
        walk = np.array([walk_bias(value, drift, interval, rng) for value in walk])
        if frame in (10, 40):
            spread[frame] = walk.std()
            assert abs(walk.mean()) <= 4.5 * drift * math.sqrt(frame * interval / walks)
    # After one second the spread is the drift itself; after four seconds twice that. The sample standard
    # deviation of 4000 normals is within 1.1 % of the truth (one sigma): allow 5 %.
    assert spread[10] == pytest.approx(drift, rel=0.05)
    assert spread[40] == pytest.approx(2.0 * drift, rel=0.05)


def test_the_noise_floor_has_the_set_standard_deviation() -> None:
    rng, draws = np.random.default_rng(2), 5000
    rotation, translation = rotation_from_vector(ROTATION_VECTOR), np.array([0.1, 0.0, 0.5])
    rotation_noise, translation_noise = [], []
    for _ in range(draws):
        told_rotation, told_translation = add_motion_noise(rotation, translation, 0.5, 0.02, rng)
        # The noise rotation acts after the true one: told = noise @ true.
        rotation_noise.append(np.rad2deg(vector_from_rotation(told_rotation @ rotation.T)))
        translation_noise.append(told_translation - translation)
    rotation_noise, translation_noise = np.array(rotation_noise), np.array(translation_noise)
    # Per axis: 5000 draws estimate a standard deviation within 1 % (one sigma); allow 5 %.
    np.testing.assert_allclose(rotation_noise.std(axis=0), 0.5, rtol=0.05)
    np.testing.assert_allclose(translation_noise.std(axis=0), 0.02, rtol=0.05)
    np.testing.assert_allclose(rotation_noise.mean(axis=0), 0.0, atol=4.5 * 0.5 / math.sqrt(draws))


def test_log_normal_depth_noise_has_the_set_sigma_of_log_ratios() -> None:
    depths = np.random.default_rng(3).uniform(0.5, 12.0, 20000)
    noisy, keep = corrupt_depths(depths, 0.3, 0.0, 0.0, 0.5, 13.0, np.random.default_rng(4))
    log_ratio = np.log(noisy / depths)
    assert log_ratio.std() == pytest.approx(0.3, rel=0.03) and abs(log_ratio.mean()) <= 0.01
    assert keep.all()


def test_outliers_replace_the_set_fraction_log_uniformly_over_the_range() -> None:
    depths = np.full(20000, 4.0)
    corrupted, keep = corrupt_depths(depths, 0.0, 0.25, 0.0, 0.5, 13.0, np.random.default_rng(5))
    replaced = corrupted != 4.0
    assert _binomial_ok(int(replaced.sum()), len(depths), 0.25) and keep.all()
    assert np.all((corrupted[replaced] >= 0.5) & (corrupted[replaced] <= 13.0))
    # Log-uniform: the logarithms are uniform, with mean halfway between the ends' logarithms.
    logs = np.log(corrupted[replaced])
    assert logs.mean() == pytest.approx((math.log(0.5) + math.log(13.0)) / 2.0, abs=0.03)
    assert depths[0] == 4.0  # the input is not changed in place
    everything, _ = corrupt_depths(depths, 0.0, 1.0, 0.0, 0.5, 13.0, np.random.default_rng(6))
    assert np.count_nonzero(everything == 4.0) == 0


def test_dropout_removes_the_set_fraction() -> None:
    depths = np.full(20000, 3.0)
    kept_depths, keep = corrupt_depths(depths, 0.0, 0.0, 0.4, 0.5, 13.0, np.random.default_rng(7))
    assert _binomial_ok(int((~keep).sum()), len(depths), 0.4) and kept_depths is depths
    _, none_kept = corrupt_depths(depths, 0.0, 0.0, 1.0, 0.5, 13.0, np.random.default_rng(8))
    assert not none_kept.any()


def test_outlier_range_comes_from_the_bin_edges() -> None:
    assert outlier_depth_range(DEFAULT_BIN_EDGES) == (0.5, 13.0)  # first edge 0: half the second
    assert outlier_depth_range((0.2, 1.0, 4.0)) == (0.2, 4.0)
    with pytest.raises(ValueError, match=r"^outlier depths need 0 < low < high, got low=0.0, high=13.0$"):
        corrupt_depths(np.ones(3), 0.0, 0.1, 0.0, 0.0, 13.0, np.random.default_rng())


def test_a_lagged_attitude_is_the_interpolation_back_toward_the_previous_frame() -> None:
    previous = rotation_from_vector(np.array([0.0, 0.0, 0.1]))
    current = rotation_from_vector(np.array([0.0, 0.0, 0.3]))
    assert lagged_attitude(previous, current, 0.0) is current
    np.testing.assert_allclose(lagged_attitude(previous, current, 1.0), previous, atol=1e-12)
    np.testing.assert_allclose(
        lagged_attitude(previous, current, 5.0), previous, atol=1e-12
    )  # capped at a frame
    halfway = vector_from_rotation(lagged_attitude(previous, current, 0.25))
    np.testing.assert_allclose(halfway, [0.0, 0.0, 0.25], atol=1e-12)


def _told_yaw_steps(offset_ms: float, yaw_per_frame: list[float]) -> list[float]:
    """Yaw told per frame by the pipeline (10 Hz) for a camera turning by these angles (rad) about its y axis."""
    from flownav_env.sensor import SensorPipeline
    from flownav_env.settings import SensorSettings

    sensor = SensorSettings(imu_time_offset_ms=offset_ms)
    pipeline, rng = SensorPipeline(10.0), np.random.default_rng(0)
    angle, position = 0.0, np.zeros(3)
    pipeline.start((np.eye(3), position))
    told = []
    for step in yaw_per_frame:
        angle += step
        frame = pipeline.motion(sensor, rng, (rotation_from_vector(np.array([0.0, angle, 0.0])), position))
        told.append(-vector_from_rotation(frame.told_motion[0])[1])
    return told


def test_a_clock_offset_leaves_a_steady_turn_and_turns_a_change_of_rate_into_an_error() -> None:
    steps = [0.0, 0.0, 0.05, 0.05, 0.05, 0.0]  # start turning at frame 3, stop at frame 6
    np.testing.assert_allclose(_told_yaw_steps(0.0, steps), steps, atol=1e-12)
    told = _told_yaw_steps(20.0, steps)  # 20 ms at 10 Hz: a fifth of a frame late
    np.testing.assert_allclose(told, [0.0, 0.0, 0.04, 0.05, 0.05, 0.01], atol=1e-12)


def test_a_negative_clock_offset_is_refused_with_its_range() -> None:
    from flownav_env.settings import SensorSettings

    with pytest.raises(ValueError, match=re.escape("imu_time_offset_ms must be in [0.0, 100.0], got -5.0")):
        SensorSettings(imu_time_offset_ms=-5.0)
