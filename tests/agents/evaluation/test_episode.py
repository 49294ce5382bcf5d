"""One episode's record: what run_episode measures along the flight."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
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
