"""A curriculum's later stage (``init_from``): starts from an earlier stage's weights, records the earlier
stage's cost, and refuses a file that is missing or does not fit its network, with a message saying why."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
import torch
from helpers import tiny_train_config

from agents.common.saved_models import load_policy_weights, read_saved_model
from agents.common.yaml_config import ConfigError, load_config
from agents.training.envs import build_envs, close_quietly
from agents.training.outputs import RunFiles
from agents.training.ppo import new_model, train
from agents.training.train_config import TrainConfig, init_source


@pytest.fixture(scope="module")
def stage_one(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A tiny first stage, its policy and record copied as shipped seeds are named (``seed_3.zip``)."""
    tmp_path = tmp_path_factory.mktemp("stage_one")
    config, config_path = tiny_train_config(tmp_path, total=64, name="stage_one", seed=3)
    train(config, config_path=config_path, resume=False, runs_dir=tmp_path / "runs", progress_bar=False)
    files = RunFiles.of(tmp_path / "runs", "stage_one")
    shipped = tmp_path / "shipped"
    shipped.mkdir()
    shutil.copyfile(files.policy, shipped / "seed_3.zip")
    shutil.copyfile(files.record, shipped / "seed_3.json")
    return shipped


def test_a_later_stage_starts_from_the_earlier_weights_of_its_own_seed(
    stage_one: Path, tmp_path: Path
) -> None:
    config, _ = tiny_train_config(tmp_path, total=64, seed=3, init_from=str(stage_one / "seed_{seed}.zip"))
    assert init_source(config) == stage_one / "seed_3.zip"
    envs, eval_env = build_envs(config, in_process=True)
    try:
        model = new_model(config, envs)
        saved = load_policy_weights(model, init_source(config))
        for name, value in model.policy.state_dict().items():
            assert torch.equal(value, saved.policy_state[name]), name
    finally:
        close_quietly(envs)
        close_quietly(eval_env)


def test_a_later_stage_records_the_earlier_stage_and_the_summed_cost(stage_one: Path, tmp_path: Path) -> None:
    config, config_path = tiny_train_config(
        tmp_path, total=64, name="stage_two", seed=3, init_from=str(stage_one / "seed_{seed}.zip")
    )
    train(config, config_path=config_path, resume=False, runs_dir=tmp_path / "runs", progress_bar=False)
    record = json.loads(RunFiles.of(tmp_path / "runs", "stage_two").record.read_text())
    earlier = json.loads((stage_one / "seed_3.json").read_text())
    assert record["init_from"] == {
        "path": str(stage_one / "seed_3.zip"),
        "timesteps": earlier["total_timesteps"],
        "wall_minutes": earlier["total_wall_minutes"],
    }
    assert record["total_wall_minutes_with_init"] == pytest.approx(
        record["total_wall_minutes"] + earlier["total_wall_minutes"], abs=0.11
    )


def test_weights_of_another_network_are_refused_naming_the_file(stage_one: Path, tmp_path: Path) -> None:
    config, _ = tiny_train_config(tmp_path, total=64, ppo={"n_steps": 64, "batch_size": 32, "net_arch": [8]})
    envs, eval_env = build_envs(config, in_process=True)
    try:
        model = new_model(config, envs)
        before = {name: value.clone() for name, value in model.policy.state_dict().items()}
        with pytest.raises(ValueError, match=r"seed_3.zip: its policy does not fit .*: saved \(16, "):
            load_policy_weights(model, stage_one / "seed_3.zip")
        with pytest.raises(FileNotFoundError, match=r"model file not found: .*seed_9.zip"):
            load_policy_weights(model, stage_one / "seed_9.zip")
        assert read_saved_model(stage_one / "seed_3.zip").num_timesteps >= 64
        assert all(torch.equal(value, model.policy.state_dict()[name]) for name, value in before.items())
    finally:
        close_quietly(envs)
        close_quietly(eval_env)


def test_init_from_may_name_only_the_seed(tmp_path: Path) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text("name: x\ninit_from: results/policies/{name}/seed_{seed}.zip\n")
    with pytest.raises(ConfigError, match=r"key 'init_from' may hold only the placeholder \{seed\}") as error:
        load_config(path, TrainConfig)
    assert str(path) in str(error.value)
