"""PPO training from a config, its resume and record, and sensor randomisation."""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import pytest
import yaml

import flownav_env  # noqa: F401
from agents.common.config import ConfigError, check_env_kwargs, load_config
from agents.common.seeds import TEST_SEED_START
from agents.policies import load_agent
from agents.training.config import TrainConfig
from agents.training.ppo import latest_checkpoint, train
from agents.training.wrappers import SensorRandomization

SMALL = {"camera_width": 96, "camera_height": 72}


def tiny_train_config(tmp_path: Path, total: int) -> tuple[TrainConfig, Path]:
    config_path = tmp_path / "tiny.yaml"
    config_path.write_text(
        yaml.safe_dump(
            {
                "name": "ppo_flow",
                "env_id": "FlowNavSingle-v0",
                "env": SMALL,
                "total_timesteps": total,
                "n_envs": 1,
                "checkpoint_every": 128,
                "eval_every": 128,
                "eval_episodes": 1,
                "ppo": {"n_steps": 64, "batch_size": 32, "n_epochs": 1, "net_arch": [16]},
            }
        )
    )
    return load_config(config_path, TrainConfig), config_path


def test_tiny_ppo_run_saves_loads_and_resumes(tmp_path: Path) -> None:
    from stable_baselines3 import PPO

    config, path = tiny_train_config(tmp_path, total=128)
    policy = train(
        config, config_path=path, resume=False, runs_dir=tmp_path / "runs", policies_dir=tmp_path / "pol"
    )
    checkpoints = tmp_path / "runs" / "ppo_flow" / "checkpoints"
    assert PPO.load(latest_checkpoint(checkpoints), device="cpu").num_timesteps == 128
    assert (tmp_path / "pol" / "ppo_flow.yaml").exists() and (tmp_path / "pol" / "ppo_flow.json").exists()

    config.total_timesteps = 256  # as if the first run had been interrupted at 128 of 256 steps
    policy = train(
        config, config_path=path, resume=True, runs_dir=tmp_path / "runs", policies_dir=tmp_path / "pol"
    )
    assert PPO.load(latest_checkpoint(checkpoints), device="cpu").num_timesteps == 256
    record = json.loads((tmp_path / "pol" / "ppo_flow.json").read_text())
    assert record["total_timesteps"] == 256 and len(record["sessions"]) == 2
    assert record["sessions"][-1]["env_estimator_defaults"] == {"fast_threshold": 10}
    assert record["sessions"][-1]["code"].startswith("commit") and record["sessions"][-1]["gl_renderer"]
    assert record["selected"].startswith("best held-out eval")  # the shipped policy is the best evaluated one

    agent = load_agent("ppo_flow", policy)
    env = gym.make("FlowNavSingle-v0", **SMALL)
    observation, _ = env.reset(seed=TEST_SEED_START)
    action, _ = agent.predict(observation, deterministic=True)
    env.close()
    assert action.shape == (3,)


def test_sensor_randomization_draws_within_ranges_reproducibly() -> None:
    def draws(seed: int) -> dict:
        env = SensorRandomization(
            gym.make("FlowNav-v0", **SMALL), {"rotation_error": [0.0, 0.1], "brightness": [0.5, 1.5]}
        )
        _, info = env.reset(seed=seed)
        env.close()
        return info

    first, again, other = draws(3), draws(3), draws(4)
    assert 0.0 <= first["sensor_rotation_error"] <= 0.1 and 0.5 <= first["sensor_brightness"] <= 1.5
    assert first["sensor_rotation_error"] == again["sensor_rotation_error"]
    assert first["sensor_rotation_error"] != other["sensor_rotation_error"]
    with pytest.raises(ValueError, match=r"ranges may only name .*got \['speed'\]"):
        SensorRandomization(gym.make("FlowNav-v0", **SMALL), {"speed": [0, 1]})


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ({"name": "x", "total_steps": 5}, r"unknown key 'total_steps'"),
        ({"name": "x", "n_envs": "two"}, r"key 'n_envs' must be an integer, got 'two'"),
        ({"name": "x", "n_envs": 0}, r"key 'n_envs' must be in \[1, 64\], got 0"),
        ({"name": "x", "ppo": {"gamma": 1.5}}, r"key 'ppo.gamma' must be in \[0.0, 1.0\], got 1.5"),
        ({"name": "x", "ppo": {"lr": 0.1}}, r"unknown key 'ppo.lr'"),
        (
            {"name": "x", "randomize": {"brightness": [2.0, 1.0]}},
            r"randomize.brightness' must be \[low, high\]",
        ),
        ({"name": "x", "env": {"forward_speed": -1}}, r"key 'env.forward_speed': forward_speed must be in"),
        ({"name": "x", "env": {"wind": 3}}, r"unknown key 'env.wind' \(not a FlowNavEnv argument\)"),
        ({"n_envs": 2}, r"missing required key 'name'"),
    ],
)
def test_train_config_errors_name_the_file_and_the_key(tmp_path: Path, content: dict, message: str) -> None:

    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(content))
    with pytest.raises(ConfigError, match=message) as error:
        config = load_config(path, TrainConfig)
        check_env_kwargs(config.env, str(path))
    assert str(path) in str(error.value)
