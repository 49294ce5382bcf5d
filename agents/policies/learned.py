"""Learned agents: where a trained policy is stored, the env settings it was trained with, and loading any
agent by name (a reactive one is built, a learned one is loaded from its ``.zip``)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from agents.common.config import load_config
from agents.policies.base import AGENT_NAMES, LEARNED_AGENTS, Agent
from agents.policies.reactive import BeeAgent, StraightAgent
from agents.training.config import TrainConfig


def policy_file(
    name: str, path: str | Path | None = None, directory: str | Path = "results/policies"
) -> Path:
    """Where the learned agent ``name`` is stored: ``path`` if given, else ``<directory>/<name>.zip``."""
    return Path(path) if path else Path(directory) / f"{name}.zip"


def agent_env_kwargs(name: str, path: str | Path | None = None) -> dict[str, Any]:
    """The env kwargs an agent must be evaluated with, whatever the sensor cell: for a learned agent, the
    ``env`` section of the training config saved beside its ``.zip`` (an oracle policy flies on oracle
    observations, a policy trained at another resolution keeps it); empty for hand-written agents or when
    no config copy exists. A sweep cell's own kwargs go on top of these.
    """
    if name not in LEARNED_AGENTS:
        return {}
    config_path = policy_file(name, path).with_suffix(".yaml")
    if not config_path.is_file():
        return {}
    return dict(load_config(config_path, TrainConfig).env)


def load_agent(name: str, policy_path: str | Path | None = None, **bee_params: float) -> Agent:
    """The agent called ``name`` (see :data:`AGENT_NAMES`).

    Args:
        name: agent name.
        policy_path: for PPO agents, the ``.zip`` to load; defaults to ``results/policies/<name>.zip``.
        bee_params: overrides of :class:`BeeAgent` gains.

    Raises:
        ValueError: unknown name. FileNotFoundError: a PPO policy file is missing.
    """
    if name == "straight":
        return StraightAgent()
    if name == "bee":
        return BeeAgent(**bee_params)
    if name in LEARNED_AGENTS:
        from stable_baselines3 import PPO

        path = policy_file(name, policy_path)
        if not path.is_file():
            raise FileNotFoundError(f"policy file for agent {name!r} not found: {path} (train it first)")
        return PPO.load(path, device="cpu")
    raise ValueError(f"agent must be one of {', '.join(AGENT_NAMES)}, got {name!r}")
