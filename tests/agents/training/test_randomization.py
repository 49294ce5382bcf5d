"""Training randomisation of the course (speed, obstacle density): drawn before each reset, reproducible from the
seed, checked against the settings' ranges, with a time limit long enough for the slowest speed."""

from __future__ import annotations

from dataclasses import fields

import gymnasium as gym
import numpy as np
import pytest

import flownav_env  # noqa: F401
from agents.training.envs import make_env_factory
from agents.training.train_config import Randomization, TrainConfig
from agents.training.wrappers import SensorRandomization
from flownav_env.settings import COURSE_FIELDS, SENSOR_FIELDS

SMALL = {"camera_width": 64, "camera_height": 48, "depth_error_info": False}


def _course_draws(seed: int, episodes: int) -> list[tuple[float, float, int]]:
    env = SensorRandomization(
        gym.make("FlowNav-v0", **SMALL), {"forward_speed": [0.5, 2.0], "obstacle_density": [0.06, 0.18]}
    )
    draws = []
    for episode in range(episodes):
        _, info = env.reset(seed=seed if episode == 0 else None)
        base = env.unwrapped
        draws.append(
            (
                info["sensor_forward_speed"],
                info["sensor_obstacle_density"],
                len(base.physics.obstacle_positions),
            )
        )
        assert base.forward_speed == info["sensor_forward_speed"]
        assert base.physics.velocity_world()[0] == pytest.approx(base.forward_speed)  # the start uses it
    env.close()
    return draws


def test_the_course_is_drawn_before_each_reset_and_reproducible() -> None:
    first, again = _course_draws(3, 4), _course_draws(3, 4)
    assert first == again
    speeds, densities, counts = zip(*first, strict=True)
    assert all(0.5 <= s <= 2.0 for s in speeds) and all(0.06 <= d <= 0.18 for d in densities)
    assert len(set(speeds)) == 4
    # Denser courses stand more capsules (up to the placement's rejections).
    assert counts[int(np.argmax(densities))] > counts[int(np.argmin(densities))]


def test_out_of_range_course_ends_are_refused() -> None:
    env = gym.make("FlowNav-v0", **SMALL)
    with pytest.raises(ValueError, match=r"forward_speed must be in \[0.0, 5.0\], got 9.0"):
        SensorRandomization(env, {"forward_speed": [0.5, 9.0]})
    with pytest.raises(
        ValueError, match=r"ranges may only name .*forward_speed, obstacle_density, got \['field_length'\]"
    ):
        SensorRandomization(env, {"field_length": [10.0, 20.0]})
    with pytest.raises(
        ValueError, match=r"not course settings: \['brightness'\]; allowed: forward_speed, obstacle_density"
    ):
        env.unwrapped.set_course(brightness=0.5)
    env.close()


def test_training_envs_get_the_time_limit_of_the_slowest_speed() -> None:
    config = TrainConfig(name="course", env=dict(SMALL), randomize=Randomization(forward_speed=[0.5, 1.5]))
    env = make_env_factory(config, 0)()
    assert env.spec.max_episode_steps == 800  # 20 m at 0.5 m/s, twice over, at 10 frames/s
    env.close()
    plain = make_env_factory(TrainConfig(name="plain", env=dict(SMALL)), 0)()
    assert plain.spec.max_episode_steps == 400
    plain.close()


def test_training_may_randomise_every_sensor_and_course_setting_the_env_declares() -> None:
    assert [item.name for item in fields(Randomization)] == [*SENSOR_FIELDS, *COURSE_FIELDS]
    assert "translation_noise_correlation_s" in SENSOR_FIELDS  # the field the hand-written list once missed


def test_the_velocity_errors_correlation_time_is_drawn_per_episode() -> None:
    config = TrainConfig(
        name="t", env=dict(SMALL), randomize=Randomization(translation_noise_correlation_s=[0.5, 2.0])
    )
    env = make_env_factory(config, 0)()
    try:
        drawn = set()
        for episode in range(3):
            env.reset(seed=11 if episode == 0 else None)
            drawn.add(env.unwrapped.settings.translation_noise_correlation_s)
    finally:
        env.close()
    assert len(drawn) == 3 and all(0.5 <= value <= 2.0 for value in drawn)


def test_a_reversed_range_is_one_line() -> None:
    with pytest.raises(
        ValueError, match=r"^key 'randomize.translation_noise_correlation_s' must be \[low, high\]"
    ):
        Randomization(translation_noise_correlation_s=[2.0, 0.5]).validate()
