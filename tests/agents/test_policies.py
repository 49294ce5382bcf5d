"""Reactive and learned agents behind one predict interface."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import flownav_env  # noqa: F401
from agents.evaluation.episode import run_episode
from agents.policies import BeeAgent, StraightAgent, load_agent, sector_nearness

SMALL = {"camera_width": 96, "camera_height": 72}


def test_bee_passes_the_single_capsule_where_straight_collides() -> None:
    env = gym.make("FlowNavSingle-v0")
    straight = run_episode(env, StraightAgent(), seed=0, label="straight")
    bee = run_episode(env, BeeAgent(), seed=0, label="bee")
    env.close()
    assert straight.collision and not straight.success
    assert bee.success and not bee.collision
    assert bee.min_clearance_m > 0.2


def test_agents_accept_batched_observations_like_sb3() -> None:
    env = gym.make("FlowNav-v0", **SMALL)
    observation, _ = env.reset(seed=0)
    observation, *_ = env.step(np.zeros(3))
    env.close()
    batch = {key: np.stack([value, value]) for key, value in observation.items()}
    for agent in (BeeAgent(), StraightAgent()):
        single, _ = agent.predict(observation)
        batched, _ = agent.predict(batch)
        assert single.shape == (3,) and batched.shape == (2, 3)
        np.testing.assert_allclose(batched[0], single)
        assert np.all(np.abs(single) <= 1)


def test_bee_turns_away_from_the_nearer_side() -> None:
    histogram = np.zeros((3, 5, 6), np.float32)
    histogram[:2, 0, 0] = 1.0  # something within 1 m on the left
    histogram[:2, 4, 5] = 1.0  # the right side is far
    state = np.array([1.0, 0, 0, 0, 0, 1.0, 0.0], np.float32)
    action, _ = BeeAgent().predict({"depth_histogram": histogram, "state": state})
    assert action[0] > 0.5  # slides right
    assert sector_nearness(histogram, BeeAgent().bin_edges)[0, 0] == pytest.approx(2.0)


def test_unknown_agent_and_missing_policy_errors(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=r"agent must be one of .*got 'wasp'"):
        load_agent("wasp")
    with pytest.raises(FileNotFoundError, match=r"policy file for agent 'ppo_flow' not found"):
        load_agent("ppo_flow", tmp_path / "none.zip")
