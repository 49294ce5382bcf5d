"""Config loading and the shipped configs."""

from __future__ import annotations

from pathlib import Path

import pytest

import flownav_env  # noqa: F401
from agents.common.locations import CONFIGS_DIR
from agents.common.yaml_config import ConfigError, load_config
from agents.evaluation.sweep import SWEEP_FACTORS, SweepConfig
from agents.training.train_config import TrainConfig
from flownav_env.settings_check import check_env_kwargs


def test_config_file_errors(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="config file not found"):
        load_config(tmp_path / "missing.yaml", TrainConfig)
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: [unclosed")
    with pytest.raises(ConfigError, match="not valid YAML"):
        load_config(bad, TrainConfig)


def test_shipped_configs_load() -> None:
    root = CONFIGS_DIR
    for name in ("ppo_flow", "ppo_robust", "ppo_oracle"):
        assert load_config(root / f"{name}.yaml", TrainConfig).name == name
    for experiment in sorted((root / "experiments").glob("*.yaml")):
        config = load_config(experiment, TrainConfig)
        assert config.name == experiment.stem and check_env_kwargs(config.env, str(experiment)) == config.env
    sweep = load_config(root / "sweep_v2.yaml", SweepConfig)
    assert set(sweep.factors) == set(SWEEP_FACTORS)  # the benchmark sweep covers every error model
    assert all(len(levels) >= 2 for levels in sweep.factors.values())
    # v0's sweep keeps its factors, each of which the v2 sweep flies at the same levels.
    for factor, levels in load_config(root / "sweep.yaml", SweepConfig).factors.items():
        assert set(levels) <= set(sweep.factors[factor])
    for sweep in sorted(root.glob("sweep_*.yaml")):
        config = load_config(sweep, SweepConfig)
        assert check_env_kwargs(config.env, str(sweep)) == config.env
