"""The training config: its refusals, the command line's overrides, and every shipped training YAML."""

from __future__ import annotations

import re
from dataclasses import asdict
from pathlib import Path

import pytest
import yaml

from agents.common.locations import CONFIGS_DIR, RESULTS_DIR
from agents.common.yaml_config import ConfigError, from_mapping, load_config
from agents.training.train_config import (
    PPOParams,
    TrainConfig,
    checked_config,
    field_bounds,
    init_source,
    override,
)


def _training_yamls() -> list[Path]:
    """Each committed training config: configs/ (those with a ``name``) and the YAML beside each policy."""
    candidates = [*CONFIGS_DIR.glob("*.yaml"), *(CONFIGS_DIR / "experiments").glob("*.yaml")]
    shipped = [*(RESULTS_DIR / "policies").glob("*/seed_*.yaml"), *(RESULTS_DIR / "policies").glob("*.yaml")]
    training = [p for p in candidates if "name" in (yaml.safe_load(p.read_text()) or {})]
    return sorted(training) + sorted(shipped)


def test_every_committed_training_config_loads() -> None:
    paths = _training_yamls()
    assert len(paths) > 20
    for path in paths:
        config = load_config(path, TrainConfig)
        assert isinstance(config.ppo, PPOParams) and checked_config(config, str(path)) == config


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"name": "x", "n_envs": 0}, "key 'n_envs' must be in [1, 64], got 0"),
        ({"name": "x", "ppo": {"gamma": 1.5}}, "key 'ppo.gamma' must be in [0.0, 1.0], got 1.5"),
        ({"name": "x", "ppo": {"net_arch": [64, 0]}}, "key 'ppo.net_arch' must be in [1, 4096], got [64, 0]"),
        ({"name": "x", "ppo": {"gama": 0.9}}, "unknown key 'ppo.gama' (allowed at ppo: batch_size, "),
        ({"name": "x", "seed": "1"}, "key 'seed' must be an integer, got '1'"),
        ({"name": "x", "imitation": {"rounds": 0}}, "key 'imitation.rounds' must be in [1, 100], got 0"),
        (
            {"name": "x", "randomize": {"brightness": [0.5, 9.0]}},
            "key 'randomize.brightness': brightness must be in [0.0, 4.0], got 9.0",
        ),
        (
            {"name": "x", "randomize": {"brightness": [1.5, 0.5]}},
            "key 'randomize.brightness' must be [low, high] with low <= high, got [1.5, 0.5]",
        ),
        ({"name": "x", "init_from": "a/{run}.zip"}, "key 'init_from' may hold only the placeholder {seed}"),
        ({"n_envs": 2}, "missing required key 'name'"),
    ],
)
def test_a_bad_training_config_is_refused_in_one_line(data: dict, message: str) -> None:
    with pytest.raises(ConfigError, match=f"^run.yaml: {re.escape(message)}"):
        from_mapping(data, TrainConfig, source="run.yaml")


def test_a_value_set_after_loading_is_checked_again() -> None:
    config = TrainConfig(name="x", seed=3, init_from="runs/seed_{seed}.zip")
    assert checked_config(config, "cli") == config and init_source(config) == Path("runs/seed_3.zip")
    config.frame_stack = 0
    with pytest.raises(ConfigError, match=r"^cli: key 'frame_stack' must be in \[1, 16\], got 0$"):
        checked_config(config, "cli")
    assert asdict(TrainConfig(name="x"))["ppo"]["net_arch"] == [64, 64]


def test_an_override_is_checked_against_the_range_declared_on_its_field() -> None:
    assert field_bounds("n_envs") == (1, 64)
    config = TrainConfig(name="x")
    override(config, "max_minutes", None, "--max-minutes")
    override(config, "max_minutes", 5.0, "--max-minutes")
    assert config.max_minutes == 5.0
    with pytest.raises(
        ValueError, match=re.escape("--n-envs must be in [1, 64] (the config's n_envs range), got 65")
    ):
        override(config, "n_envs", 65, "--n-envs")
    assert config.n_envs == 2
