"""Misuse of the env fails at once with one clear line: a closed env, a wrong action, an unsupported render
mode; and Gymnasium's array wrappers work over FlattenObservation, as the README shows."""

from __future__ import annotations

from collections.abc import Iterator

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.wrappers import FlattenObservation, NormalizeObservation

import flownav_env  # noqa: F401  (registers the ids)
from flownav_env import FlowNavEnv

SMALL = {"camera_width": 96, "camera_height": 72}


@pytest.fixture(scope="module")
def env() -> Iterator[FlowNavEnv]:
    # Shared: every bad action below is refused before the env changes.
    env = FlowNavEnv(**SMALL)
    env.reset(seed=0)
    yield env
    env.close()


def test_render_after_close_raises_as_step_does() -> None:
    env = FlowNavEnv(**SMALL, render_mode="rgb_array")
    env.reset(seed=0)
    assert env.render().shape == (240, 640, 3)
    env.close()
    with pytest.raises(RuntimeError, match=r"render\(\) called on a closed FlowNavEnv; make a new env"):
        env.render()
    with pytest.raises(RuntimeError, match=r"step\(\) called on a closed FlowNavEnv; make a new env"):
        env.step(np.zeros(3))


@pytest.mark.parametrize(
    ("action", "shape"),
    [
        (np.zeros((1, 3)), r"\(1, 3\)"),
        (np.zeros((3, 1)), r"\(3, 1\)"),
        (np.zeros(2), r"\(2,\)"),
        ([0.0, 0.0, 0.0, 0.0], r"\(4,\)"),
        (0.5, r"\(\)"),
    ],
)
def test_action_of_another_shape_is_rejected_naming_both_shapes(
    env: FlowNavEnv, action: object, shape: str
) -> None:
    with pytest.raises(ValueError, match=rf"^action must have shape \(3,\), got shape {shape}$"):
        env.step(action)


@pytest.mark.parametrize("action", [["a", "b", "c"], [0.0, [0.0, 0.0], 0.0], {"x": 1.0}])
def test_action_that_is_not_numbers_is_rejected(env: FlowNavEnv, action: object) -> None:
    with pytest.raises(
        ValueError, match=rf"^action must be numbers of shape \(3,\), got {type(action).__name__}: "
    ):
        env.step(action)


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_non_finite_action_is_rejected_before_clipping(env: FlowNavEnv, value: float) -> None:
    # Clipping used to turn an infinite value into a full command without a word.
    with pytest.raises(ValueError, match=r"^action must be finite, got array\(\["):
        env.step(np.array([0.0, value, 0.0]))


def test_three_plain_numbers_fly_as_the_same_array() -> None:
    from_list, from_array = FlowNavEnv(**SMALL), FlowNavEnv(**SMALL)
    try:
        from_list.reset(seed=3)
        from_array.reset(seed=3)
        for action in ([0.4, -2.0, 0.25], [-0.3, 0.1, 0.0]):
            observed = from_list.step(action)[0]
            expected = from_array.step(np.array(action))[0]
            for key, value in expected.items():
                np.testing.assert_array_equal(observed[key], value)
    finally:
        from_list.close()
        from_array.close()


@pytest.mark.parametrize("mode", ["human", "rgb_array_list", "rgb"])
def test_gym_make_rejects_an_unsupported_render_mode_when_it_makes_the_env(mode: str) -> None:
    # "human" used to get Gymnasium's HumanRendering wrapper, which asked for pygame at the first reset.
    with pytest.raises(ValueError, match=rf"^render_mode must be one of 'rgb_array', got '{mode}'$"):
        gym.make("FlowNav-v0", render_mode=mode, **SMALL)


def test_gym_make_renders_rgb_array() -> None:
    env = gym.make("FlowNavSingle-v0", render_mode="rgb_array", **SMALL)
    try:
        env.reset(seed=0)
        assert env.render().shape == (240, 640, 3)
    finally:
        env.close()


def test_normalize_observation_over_flatten_observation_resets_and_steps() -> None:
    env = NormalizeObservation(FlattenObservation(gym.make("FlowNav-v0", **SMALL)))
    try:
        observation, _ = env.reset(seed=0)
        assert observation.shape == env.observation_space.shape
        for _ in range(3):
            observation, reward, *_ = env.step(env.action_space.sample())
        assert observation.shape == env.observation_space.shape
        assert np.all(np.isfinite(observation)) and np.isfinite(reward)
    finally:
        env.close()
