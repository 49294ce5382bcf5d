"""Helpers shared by several test modules: small env settings and a tiny training config.

Test modules import them as ``from helpers import ...``: pytest puts ``tests/`` on the import path because
``tests/conftest.py`` lives there, so this works under bare ``pytest`` as well as ``python -m pytest``.
"""

from __future__ import annotations

from pathlib import Path

import yaml

from agents.common.yaml_config import load_config
from agents.training.train_config import TrainConfig

# The real third-party images with ground truth, in ../shared beside the repository.
TESTDATA = Path(__file__).resolve().parents[2] / "shared" / "testdata"

SMALL = {"camera_width": 96, "camera_height": 72}


def tiny_train_config(
    directory: Path, total: int, name: str = "tiny_ppo", **keys
) -> tuple[TrainConfig, Path]:
    config_path = directory / f"{name}_config.yaml"
    content = {
        "name": name,
        "env_id": "FlowNavSingle-v0",
        "env": SMALL,
        "total_timesteps": total,
        "n_envs": 1,
        "checkpoint_every": 64,
        "eval_every": 64,
        "eval_episodes": 1,
        "ppo": {"n_steps": 64, "batch_size": 32, "n_epochs": 1, "net_arch": [16]},
        **keys,
    }
    config_path.write_text(yaml.safe_dump(content))
    return load_config(config_path, TrainConfig), config_path


def with_other_defaults(init, **defaults):
    """``init`` with other defaults for some keyword arguments: a re-tuned dataclass."""

    def patched(self, **kwargs):
        init(self, **{**defaults, **kwargs})

    return patched
