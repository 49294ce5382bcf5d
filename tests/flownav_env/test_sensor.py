"""flownav_env.sensor: the pure kernels, the per-frame pipeline's order and draws, the bias it keeps per episode,
the depth errors on the estimator's points, and the env's set_sensor."""

from __future__ import annotations

import inspect

import gymnasium as gym
import numpy as np
import pytest

from estimator import DepthPoints
from flownav_env import FlowNavEnv
from flownav_env.camera_convention import camera_motion_between
from flownav_env.rotations import rotation_from_vector, vector_from_rotation
from flownav_env.sensor import SensorPipeline, corrupt_motion, jitter_rotation
from flownav_env.settings import EnvSettings, SensorSettings

SMALL = {"camera_width": 64, "camera_height": 48}
TURN = rotation_from_vector([0.01, 0.03, -0.02])


def _fly(pipeline: SensorPipeline, sensor: SensorSettings, rng: np.random.Generator, frames: int) -> list:
    """The motions of ``frames`` frames along a path that turns by TURN and moves 0.1 m forward per frame."""
    pose = (np.eye(3), np.zeros(3))
    motions = [pipeline.start(pose)]
    for _ in range(frames - 1):
        pose = (pose[0] @ TURN.T, pose[1] + pose[0] @ TURN.T @ np.array([0.0, 0.0, 0.1]))
        motions.append(pipeline.motion(sensor, rng, pose))
    return motions


def test_kernels_draw_nothing_when_off() -> None:
    rng = np.random.default_rng(0)
    state = rng.bit_generator.state
    np.testing.assert_array_equal(jitter_rotation(0.0, rng), np.eye(3))
    rotation, translation = rotation_from_vector([0.1, 0, 0]), np.ones(3)
    assert corrupt_motion(rotation, translation, 0.0, 0.0, rng) == (rotation, translation)
    assert rng.bit_generator.state == state


def test_corruption_stays_within_the_relative_error() -> None:
    told_rotation, told_translation = corrupt_motion(
        np.eye(3), np.ones(3), 0.0, 0.1, np.random.default_rng(1)
    )
    assert np.all(np.abs(told_translation - 1.0) <= 0.1) and not np.allclose(told_translation, 1.0)
    np.testing.assert_array_equal(told_rotation, np.eye(3))


def test_pipeline_order_motion_and_draws() -> None:
    sensor = SensorSettings(attitude_jitter_deg=2.0, rotation_error=0.1, translation_error=0.1)
    poses = [(np.eye(3), np.zeros(3)), (rotation_from_vector([0, 0.02, 0]), np.array([0.0, 0.0, 0.1]))]
    pipeline, rng = SensorPipeline(), np.random.default_rng(5)
    # The caller's order: jitter, (move the camera, render), the frame's motion.
    jitters = [pipeline.jitter(sensor, rng)]
    first = pipeline.start(poses[0])
    jitters.append(pipeline.jitter(sensor, rng))
    second = pipeline.motion(sensor, rng, poses[1])
    np.testing.assert_array_equal(first.true_motion[0], np.eye(3))
    assert first.told_motion is first.true_motion and first.previous_pose is poses[0]
    expected = camera_motion_between(*poses[0], *poses[1])
    np.testing.assert_array_equal(second.true_motion[0], expected[0])
    assert second.previous_pose is poses[0] and second.pose is poses[1]
    # The same generator replayed by hand: jitter, jitter, then the two error draws.
    replay = np.random.default_rng(5)
    np.testing.assert_array_equal(jitters[0], jitter_rotation(2.0, replay))
    np.testing.assert_array_equal(jitters[1], jitter_rotation(2.0, replay))
    told = corrupt_motion(*expected, 0.1, 0.1, replay)
    np.testing.assert_array_equal(second.told_motion[1], told[1])


def test_pipeline_needs_a_first_frame() -> None:
    with pytest.raises(
        ValueError, match=r"^a sequence's first frame must go through start\(\) before motion\(\)$"
    ):
        SensorPipeline().motion(SensorSettings(), np.random.default_rng(), (np.eye(3), np.zeros(3)))


def test_the_pipeline_takes_poses_not_callbacks() -> None:
    # The env moves and renders the camera itself; the sensor is handed the result, never a callback.
    for method in (SensorPipeline.jitter, SensorPipeline.start, SensorPipeline.motion):
        annotations = inspect.signature(method).parameters.values()
        assert not any("Callable" in str(parameter.annotation) for parameter in annotations), method
    assert not hasattr(SensorPipeline, "capture")


def test_env_set_sensor_checks_and_applies() -> None:
    env = FlowNavEnv(camera_width=32, camera_height=24)
    sun = float(env.physics.model.light_diffuse[env.physics.sun_light][0])
    env.set_sensor(brightness=0.5, rotation_error=0.2)
    assert (env.brightness, env.rotation_error, env.settings.sensor.brightness) == (0.5, 0.2, 0.5)
    assert float(env.physics.model.light_diffuse[env.physics.sun_light][0]) == pytest.approx(sun / 2)
    env.attitude_jitter_deg = 1.0  # assignment goes through set_sensor
    assert env.settings.attitude_jitter_deg == 1.0
    with pytest.raises(ValueError, match=r"^brightness must be in \[0.0, 4.0\], got 9$"):
        env.set_sensor(brightness=9)
    with pytest.raises(ValueError, match=r"^not sensor settings: \['frame_rate'\]"):
        env.set_sensor(frame_rate=5.0)
    with pytest.raises(AttributeError):
        env.frame_rate = 5.0
    assert env.brightness == 0.5
    env.close()


def test_pipeline_at_neutral_settings_tells_the_true_motion_without_a_draw() -> None:
    rng = np.random.default_rng(3)
    state = rng.bit_generator.state
    frames = _fly(SensorPipeline(), SensorSettings(), rng, 3)
    assert rng.bit_generator.state == state
    for frame in frames[1:]:
        assert frame.told_motion[0] is frame.true_motion[0] and frame.told_motion[1] is frame.true_motion[1]
        assert frame.bias == (0.0, 0.0)


def test_a_constant_bias_scales_every_frame_of_the_episode_without_a_draw() -> None:
    rng = np.random.default_rng(4)
    state = rng.bit_generator.state
    sensor = SensorSettings(rotation_bias=0.2, translation_bias=-0.1)
    for frame in _fly(SensorPipeline(), sensor, rng, 4)[1:]:
        true_vector, told_vector = (
            vector_from_rotation(m[0]) for m in (frame.true_motion, frame.told_motion)
        )
        np.testing.assert_allclose(told_vector, 1.2 * true_vector, rtol=1e-9)
        np.testing.assert_allclose(frame.told_motion[1], 0.9 * frame.true_motion[1], rtol=1e-12)
        assert frame.bias == (0.2, -0.1)
    assert rng.bit_generator.state == state


def test_drift_walks_the_bias_from_its_setting_and_restarts_at_every_first_frame() -> None:
    pipeline, rng = SensorPipeline(frame_rate=20.0), np.random.default_rng(5)
    sensor = SensorSettings(rotation_bias=0.1, rotation_drift=0.5)
    frames = _fly(pipeline, sensor, rng, 6)
    biases = [frame.bias[0] for frame in frames[1:]]
    assert len(set(biases)) == 5 and all(frame.bias[1] == 0.0 for frame in frames)
    # The same draws by hand: one normal per frame, standard deviation drift * sqrt(1 / frame_rate).
    replay = np.random.default_rng(5).normal(0.0, 0.5 * np.sqrt(1 / 20.0), 5)
    np.testing.assert_allclose(biases, 0.1 + np.cumsum(replay), rtol=1e-12)
    restarted = pipeline.start((np.eye(3), np.zeros(3)))
    assert restarted.bias == (0.0, 0.0) and pipeline._walk == (0.0, 0.0)
    # However far the walk goes, the applied bias stays within ±0.9 (a scale never flips sign).
    far = _fly(SensorPipeline(), SensorSettings(translation_bias=0.8, translation_drift=1.0), rng, 200)
    assert max(abs(frame.bias[1]) for frame in far) == 0.9


def test_the_noise_floor_moves_the_told_motion_of_a_still_camera() -> None:
    still = (np.eye(3), np.zeros(3))
    pipeline, rng = SensorPipeline(), np.random.default_rng(6)
    sensor = SensorSettings(rotation_noise_deg=1.0, translation_noise_m=0.01)
    pipeline.start(still)
    frame = pipeline.motion(sensor, rng, still)
    np.testing.assert_array_equal(frame.true_motion[1], np.zeros(3))
    replay = np.random.default_rng(6)
    noise_vector = np.deg2rad(replay.normal(0.0, 1.0, 3))
    np.testing.assert_allclose(vector_from_rotation(frame.told_motion[0]), noise_vector, rtol=1e-9)
    np.testing.assert_array_equal(frame.told_motion[1], replay.normal(0.0, 0.01, 3))


def _points() -> DepthPoints:
    count = 400
    valid = np.arange(count) % 4 != 0
    return DepthPoints(
        points=np.random.default_rng(0).uniform(0, 60, (count, 2)).astype(np.float32),
        next_points=np.zeros((count, 2), np.float32),
        depth=np.where(valid, 3.0, np.nan),
        valid=valid,
        tracked=np.ones(count, bool),
        parallax_px=np.ones(count),
    )


def test_corrupt_points_applies_depth_errors_to_flow_estimates_only() -> None:
    points, rng = _points(), np.random.default_rng(7)
    state = rng.bit_generator.state
    pipeline = SensorPipeline()
    assert pipeline.corrupt_points(EnvSettings(), rng, points) is points
    oracle = EnvSettings(obs_source="oracle", depth_noise=1.0, depth_dropout=0.5)
    assert pipeline.corrupt_points(oracle, rng, points) is points
    assert rng.bit_generator.state == state
    gone = pipeline.corrupt_points(EnvSettings(depth_dropout=1.0), rng, points)
    # Every valid point is gone, rows and all; the tracked points without a depth stay.
    assert len(gone.points) == 100 and not gone.valid.any() and gone.tracked.all()
    noisy = pipeline.corrupt_points(EnvSettings(depth_noise=0.5), rng, points)
    assert len(noisy.depth) == 400 and np.all(noisy.depth[noisy.valid] != 3.0)
    assert np.all(np.isnan(noisy.depth[~noisy.valid])) and np.all(points.depth[points.valid] == 3.0)


def test_env_with_full_dropout_observes_an_empty_histogram() -> None:
    env = FlowNavEnv(**SMALL, depth_dropout=1.0, observe_unresolved=True)
    env.reset(seed=0)
    for _ in range(4):
        observation, _, _, _, info = env.step(np.zeros(3))
        assert not observation["depth_histogram"].any() and info["points_valid"] == 0
        assert "depth_error_median" not in info
    # The same frames without dropout do have depths to count.
    env.set_sensor(depth_dropout=0.0)
    env.reset(seed=0)
    for _ in range(4):
        observation, _, _, _, info = env.step(np.zeros(3))
    assert observation["depth_histogram"].any() and info["points_valid"] > 0
    env.close()


def test_gym_make_takes_a_bias_and_set_sensor_changes_it_per_episode() -> None:
    env = gym.make("FlowNav-v0", rotation_bias=0.2, translation_bias=0.1, **SMALL)
    base = env.unwrapped
    told = []
    update = base.estimator.update
    base.estimator.update = lambda gray, rotation, translation: (
        told.append((rotation, translation)),
        update(gray, rotation, translation),
    )[1]

    def told_scale() -> tuple[float, float]:
        _, _, _, _, info = env.step(np.array([0.0, 0.0, 1.0]))  # yaw: a rotation to scale
        true_angle = np.linalg.norm(vector_from_rotation(info["true_rotation"]))
        angle = np.linalg.norm(vector_from_rotation(told[-1][0]))
        distance = np.linalg.norm(info["true_translation"])
        return angle / true_angle, float(np.linalg.norm(told[-1][1]) / distance)

    env.reset(seed=0)
    assert told_scale() == pytest.approx((1.2, 1.1), rel=1e-9)
    base.set_sensor(rotation_bias=-0.3)
    assert base.rotation_bias == -0.3 and base.settings.sensor.rotation_bias == -0.3
    env.reset(seed=0)
    assert told_scale() == pytest.approx((0.7, 1.1), rel=1e-9)
    base.translation_bias = 0.0  # assignment goes through set_sensor
    env.reset(seed=0)
    assert told_scale() == pytest.approx((0.7, 1.0), rel=1e-9)
    with pytest.raises(ValueError, match=r"^rotation_bias must be in \[-0.9, 0.9\], got 1.5$"):
        base.set_sensor(rotation_bias=1.5)
    env.close()
