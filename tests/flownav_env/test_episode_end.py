"""How an episode ends: exactly one outcome, by one rule, and no step after the end until a reset."""

from __future__ import annotations

import itertools

import gymnasium as gym
import numpy as np
import pytest

import flownav_env  # noqa: F401  (registers the ids)
from flownav_env.task import EPISODE_OUTCOMES, episode_outcome

SIDEWAYS = np.array([0.0, 1.0, 0.0], np.float32)


@pytest.mark.parametrize(
    ("collision", "out_of_bounds", "success"), itertools.product([False, True], repeat=3)
)
def test_every_combination_of_flags_is_exactly_one_outcome(
    collision: bool, out_of_bounds: bool, success: bool
) -> None:
    ended = episode_outcome(collision, out_of_bounds, success)
    assert ended in EPISODE_OUTCOMES
    expected = (
        "collision"
        if collision
        else "out_of_bounds"
        if out_of_bounds
        else "success"
        if success
        else "timeout"
    )
    assert ended == expected


def _small_env() -> gym.Env:
    return gym.make("FlowNav-v0", camera_width=64, camera_height=48).unwrapped


def test_step_after_termination_raises_until_reset() -> None:
    env = _small_env()
    with pytest.raises(RuntimeError, match=r"step\(\) called with no episode running.*call reset\(\) first"):
        env.step(SIDEWAYS)
    env.reset(seed=3)
    for _ in range(400):
        _, _, terminated, _, info = env.step(SIDEWAYS)
        if terminated:
            break
    assert terminated and info["out_of_bounds"] and not info["success"] and not info["collision"]
    with pytest.raises(RuntimeError, match="call reset"):
        env.step(SIDEWAYS)  # a careless loop would count the end (and its penalty) twice
    env.reset(seed=3)
    env.step(SIDEWAYS)
    env.close()
