"""Memory by frame stacking: a policy trained on VecFrameStack sees the same stacks when flown one env at a
time through ``predict``, and its config's ``frame_stack`` is checked."""

from __future__ import annotations

import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from helpers import SMALL, tiny_train_config

import flownav_env  # noqa: F401
from agents.common.yaml_config import ConfigError
from agents.evaluation.episode import run_episode
from agents.policies import load_agent
from agents.policies.stacked import FrameStackedAgent
from agents.training.outputs import RunFiles
from agents.training.ppo import train


@pytest.fixture(scope="module")
def stacked_policy(tmp_path_factory: pytest.TempPathFactory) -> Path:
    tmp_path = tmp_path_factory.mktemp("stacked")
    config, config_path = tiny_train_config(tmp_path, total=64, name="stacked", frame_stack=3)
    train(config, config_path=config_path, resume=False, runs_dir=tmp_path / "runs")
    return RunFiles.of(tmp_path / "runs", "stacked").policy


def test_a_stacked_policy_flies_single_envs_as_it_saw_vec_frame_stacks(stacked_policy: Path) -> None:
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecFrameStack

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        agent = load_agent("ppo_flow", stacked_policy)
        reference = PPO.load(stacked_policy, device="cpu")
    assert isinstance(agent, FrameStackedAgent) and agent.frame_stack == 3
    assert reference.observation_space["state"].shape == (21,)

    venv = VecFrameStack(DummyVecEnv([lambda: gym.make("FlowNavSingle-v0", **SMALL)]), 3)
    venv.seed(7)
    stacked = venv.reset()
    single = gym.make("FlowNavSingle-v0", **SMALL)
    observation, _ = single.reset(seed=7)
    state, start = None, np.ones(1, bool)
    for _ in range(12):
        expected, _ = reference.predict(stacked, deterministic=True)
        action, state = agent.predict(observation, state=state, episode_start=start, deterministic=True)
        start = np.zeros(1, bool)
        np.testing.assert_allclose(action, expected[0], rtol=1e-6, atol=1e-6)
        stacked, _, done, _ = venv.step(expected)
        observation, _, terminated, truncated, _ = single.step(action)
        assert bool(done[0]) == (terminated or truncated)
        if done[0]:
            break
    # A new episode starts from an empty stack, not from the last episode's frames.
    record = run_episode(single, agent, seed=8)
    assert record.steps >= 1
    venv.close()
    single.close()


def test_frame_stack_outside_its_range_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"frame_stack.* must be in \[1, 16\], got 0"):
        tiny_train_config(tmp_path, total=64, name="bad", frame_stack=0)
