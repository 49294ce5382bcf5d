"""Loading a trained policy's parameters without running code from its file.

``PPO.load`` unpickles the zip's ``data`` entry, and unpickling runs whatever code the file names: a crafted
policy zip can run a shell command. A FlowNav policy is a ``MultiInputPolicy`` whose network is fixed by the
training config saved beside its zip (``<name>.yaml``) and whose spaces are those of the env that config
names, so the policy is rebuilt from those and only its parameters are read from the zip (``policy.pth``,
with ``torch.load(weights_only=True)``). A zip without a config beside it is refused unless the caller opts in
(``trust_pickle=True``, ``--trust-pickle``): only then is it loaded with ``PPO.load``. Every load is checked
against the checksum manifest of the zip's folder, and every loaded policy checks that an observation has each
key it reads (:mod:`agents.policies.observation_keys`).
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any, cast

import gymnasium as gym
from gymnasium import spaces

import flownav_env  # noqa: F401  (registers the env ids that env_spaces makes)
from agents.common.manifest import manifest_problem
from agents.common.saved_models import SavedModel, load_unpickled, read_saved_model
from agents.common.yaml_config import ConfigError, load_config
from agents.policies.base import Agent
from agents.policies.observation_keys import CheckedPolicy, ObservationKeyCheck
from agents.policies.stacked import FrameStackedAgent, stacked_space
from agents.training.algorithms import algorithm_class, network_kwargs, policy_alias
from agents.training.train_config import TrainConfig


class UnverifiedPolicyWarning(UserWarning):
    """A policy file was loaded that its folder's MANIFEST.sha256 does not vouch for."""


def training_config_beside(path: Path) -> TrainConfig | None:
    """The training config saved beside the policy ``path`` (``<stem>.yaml``), or None when there is none.

    Raises:
        ConfigError (a ValueError): the config exists but does not validate; the message names it.
    """
    config_path = Path(path).with_suffix(".yaml")
    return load_config(config_path, TrainConfig) if config_path.is_file() else None


def env_spaces(env_id: str, env_kwargs: Mapping[str, object]) -> tuple[spaces.Dict, spaces.Box]:
    """The observation and action spaces of the env ``env_id`` made with ``env_kwargs`` (then closed)."""
    # Any value may come in: the env checks each setting it is made with.
    env = gym.make(env_id, **cast("dict[str, Any]", env_kwargs))
    try:
        observation_space, action_space = env.observation_space, env.action_space
    finally:
        env.close()
    if not isinstance(observation_space, spaces.Dict):
        raise ValueError(f"{env_id} observes a {type(observation_space).__name__}, not named arrays (a Dict)")
    if not isinstance(action_space, spaces.Box):
        raise ValueError(
            f"{env_id} acts with a {type(action_space).__name__}, not an array of numbers (a Box)"
        )
    return observation_space, action_space


def policy_from_parameters(saved: SavedModel, config: TrainConfig, config_path: Path | None = None) -> Agent:
    """The stable-baselines3 policy network described by ``config`` (MultiInputPolicy, or MultiInputLstmPolicy
    for a recurrent run, with its ``net_arch`` and ``log_std_init``; spaces from ``config``'s env) holding the
    parameters of ``saved``. Its ``predict``
    gives the same actions as ``PPO.load(path).predict``; a policy trained on stacked frames comes wrapped
    in a :class:`~agents.policies.stacked.FrameStackedAgent` that keeps the stack, any other in a
    :class:`~agents.policies.observation_keys.CheckedPolicy`. Either raises a ValueError naming a missing
    observation key and the env setting that gives it (``config_path``: where the config was read, for it).

    Raises:
        ValueError: the zip's network does not match the config's; the message names the file.
    """
    network = network_kwargs(config.ppo)
    saved_network = saved.data.get("policy_kwargs")
    if isinstance(saved_network, dict) and ":serialized:" not in saved_network and saved_network != network:
        raise ValueError(
            f"{saved.path}: its network {saved_network} differs from the config beside it ({network}): "
            "the config belongs to another run"
        )
    observation_space, action_space = env_spaces(config.env_id, config.env)
    policy_class = algorithm_class(config.ppo).policy_aliases[policy_alias(config.ppo)]
    policy_space = (
        stacked_space(observation_space, config.frame_stack) if config.frame_stack > 1 else observation_space
    )
    policy = policy_class(
        policy_space, action_space, lambda _: config.ppo.learning_rate, use_sde=False, **network
    )
    try:
        policy.load_state_dict(saved.policy_state)
    except RuntimeError as error:
        raise ValueError(
            f"{saved.path}: its parameters do not fit the network of the config beside it: {error}"
        ) from error
    policy.set_training_mode(False)
    check = ObservationKeyCheck(observation_space.spaces, saved.path, config_path)
    if config.frame_stack > 1:
        return FrameStackedAgent(policy, config.frame_stack, observation_space, check)
    return CheckedPolicy(policy, check)


def load_policy_file(path: Path, *, trust_pickle: bool = False) -> Agent:
    """The policy stored in ``path``, loaded without unpickling from the training config beside it; warns
    (:class:`UnverifiedPolicyWarning`) when its folder's manifest does not list it with this hash.

    Args:
        path: the policy ``.zip``.
        trust_pickle: load a zip without a config beside it with ``PPO.load``, which unpickles it and so runs
            any code it holds; without this, such a zip is refused before anything in it is read.

    Raises:
        FileNotFoundError: no such file.
        ValueError: no config beside it (unless ``trust_pickle``), not a readable stable-baselines3 policy, a
            bad config beside it, or parameters that do not fit; the message names the file and what is wrong.
    """
    path = Path(path)
    config_path = path.with_suffix(".yaml")
    if not path.is_file():
        raise FileNotFoundError(f"policy file not found: {path}")
    if not config_path.is_file() and not trust_pickle:
        # Refused before the zip is opened: the only way to load it would run what it holds.
        raise ValueError(
            f"{path} has no training config beside it (expected {config_path}), and loading it without one "
            "would unpickle it, which runs any code the file holds: put the training config it was trained "
            f"with at {config_path}, or, for a file you trust, pass --trust-pickle (trust_pickle=True in Python)"
        )
    saved = read_saved_model(path)
    try:
        config = training_config_beside(path)
    except ConfigError as error:
        raise ValueError(f"{path}: the training config beside it is invalid: {error}") from error
    problem = manifest_problem(path)
    if config is None:
        if problem:
            warnings.warn(
                UnverifiedPolicyWarning(f"{problem} (unpickled with PPO.load, as trust_pickle asked)"),
                stacklevel=3,
            )
        return _load_pickled(path)
    if problem:
        warnings.warn(
            UnverifiedPolicyWarning(f"{problem} (only its parameters are read, no code from it runs)"),
            stacklevel=3,
        )
    return policy_from_parameters(saved, config, config_path)


def _load_pickled(path: Path) -> Agent:
    # stable-baselines3 (and torch with it) is heavy: imported only when a pickled policy loads.
    from stable_baselines3 import PPO

    model = load_unpickled(PPO, path, "PPO")
    keys = getattr(model.observation_space, "spaces", {})
    return CheckedPolicy(model, ObservationKeyCheck(keys, path, None))
