"""Memory by recurrence (``ppo.lstm_hidden_size`` > 0): RecurrentPPO trains, resumes and ships like PPO, and
the shipped policy, rebuilt from its config without unpickling, carries its LSTM state through ``predict`` as
``RecurrentPPO.load`` does."""

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
from agents.training.outputs import RunFiles
from agents.training.ppo import train

RECURRENT = {"n_steps": 64, "batch_size": 32, "n_epochs": 1, "net_arch": [16], "lstm_hidden_size": 8}


@pytest.fixture(scope="module")
def recurrent_policy(tmp_path_factory: pytest.TempPathFactory) -> Path:
    tmp_path = tmp_path_factory.mktemp("recurrent")
    config, config_path = tiny_train_config(tmp_path, total=64, name="recurrent", ppo=RECURRENT)
    train(config, config_path=config_path, resume=False, runs_dir=tmp_path / "runs")
    # A second session resumes from the checkpoint with the recurrent algorithm.
    config.total_timesteps = 128
    train(config, config_path=config_path, resume=True, runs_dir=tmp_path / "runs")
    return RunFiles.of(tmp_path / "runs", "recurrent").policy


def test_a_recurrent_policy_keeps_its_lstm_state_as_recurrent_ppo_does(recurrent_policy: Path) -> None:
    from sb3_contrib import RecurrentPPO

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        agent = load_agent("ppo_flow", recurrent_policy)
        reference = RecurrentPPO.load(recurrent_policy, device="cpu")
    assert reference.num_timesteps >= 128
    env = gym.make("FlowNavSingle-v0", **SMALL)
    observation, _ = env.reset(seed=3)
    state, reference_state, start = None, None, np.ones(1, bool)
    for _ in range(10):
        action, state = agent.predict(observation, state=state, episode_start=start, deterministic=True)
        expected, reference_state = reference.predict(
            observation, state=reference_state, episode_start=start, deterministic=True
        )
        np.testing.assert_allclose(action, expected, rtol=1e-6, atol=1e-6)
        hidden, _cell = state
        assert hidden.shape == (1, 1, 8) and np.abs(hidden).sum() > 0  # the memory is carried, not reset
        start = np.zeros(1, bool)
        observation, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            break
    assert run_episode(env, agent, seed=4).steps >= 1
    env.close()


def test_frame_stacking_and_recurrence_together_are_refused(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"are two kinds of memory: use one"):
        tiny_train_config(tmp_path, total=64, name="both", frame_stack=2, ppo=RECURRENT)


def test_lstm_size_outside_its_range_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"lstm_hidden_size.* must be in \[0, 1024\], got -1"):
        tiny_train_config(tmp_path, total=64, name="bad", ppo={**RECURRENT, "lstm_hidden_size": -1})
