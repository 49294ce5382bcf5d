"""One episode's record: what run_episode measures along the flight."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from helpers import SMALL

from agents.evaluation.episode import run_episode
from agents.policies import StraightAgent


def test_the_path_length_counts_every_step_from_the_start() -> None:
    env = gym.make("FlowNav-v0", max_episode_steps=3, **SMALL)
    try:
        _, info = env.reset(seed=0)
        start = info["position"]
        record = run_episode(env, StraightAgent(), seed=0)
        end = env.unwrapped.physics.position()
    finally:
        env.close()
    assert record.steps == 3 and record.truncated
    # Flying straight ahead, the path is the distance from the start, first step included (0.1 m per step).
    assert np.isclose(record.path_length_m, np.linalg.norm(end - start), rtol=1e-3)
    assert record.path_length_m > 0.25


class GoalMover(StraightAgent):
    """An in-process agent that reaches the env and moves the goal line to just ahead of the start."""

    def __init__(self, env: gym.Env) -> None:
        super().__init__()
        self.env = env

    def predict(self, observation, state=None, episode_start=None, deterministic=True):  # type: ignore[no-untyped-def]
        self.env.unwrapped.task.goal_x = 0.1
        return super().predict(observation, state, episode_start, deterministic)


def test_a_success_needs_the_drones_own_progress_to_the_goal_line() -> None:
    env = gym.make("FlowNav-v0", **SMALL)
    try:
        with pytest.raises(
            ValueError, match=r"layout 0: a success at x = 0\.\d+ m, short of the goal line at 20\.00 m"
        ):
            run_episode(env, GoalMover(env), seed=0, label="goal_mover")
    finally:
        env.close()
