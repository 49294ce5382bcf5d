"""flownav_env.sensor: the pure kernels, the per-frame pipeline's order and draws, and the env's set_sensor."""

from __future__ import annotations

import numpy as np
import pytest

from flownav_env import FlowNavEnv
from flownav_env.camera import camera_motion_between
from flownav_env.rotations import rotation_from_vector
from flownav_env.sensor import SensorPipeline, corrupt_motion, jitter_rotation
from flownav_env.settings import SensorSettings

IMAGE = np.zeros((4, 6, 3), np.uint8)


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
    jitters: list[np.ndarray] = []

    def move(jitter: np.ndarray):
        jitters.append(jitter)
        return poses[len(jitters) - 1]

    pipeline, rng = SensorPipeline(), np.random.default_rng(5)
    first = pipeline.capture(sensor, rng, move, lambda: IMAGE, first=True)
    second = pipeline.capture(sensor, rng, move, lambda: IMAGE, first=False)
    np.testing.assert_array_equal(first.true_motion[0], np.eye(3))
    assert first.told_motion is first.true_motion and first.gray.shape == (4, 6)
    expected = camera_motion_between(*poses[0], *poses[1])
    np.testing.assert_array_equal(second.true_motion[0], expected[0])
    assert second.previous_pose is poses[0]
    # The same generator replayed by hand: jitter, jitter, then the two error draws.
    replay = np.random.default_rng(5)
    np.testing.assert_array_equal(jitters[0], jitter_rotation(2.0, replay))
    np.testing.assert_array_equal(jitters[1], jitter_rotation(2.0, replay))
    told = corrupt_motion(*expected, 0.1, 0.1, replay)
    np.testing.assert_array_equal(second.told_motion[1], told[1])


def test_pipeline_needs_a_first_frame() -> None:
    with pytest.raises(ValueError, match="must be captured with first=True"):
        SensorPipeline().capture(
            SensorSettings(), np.random.default_rng(), lambda j: None, lambda: IMAGE, False
        )


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
