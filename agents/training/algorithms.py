"""Which stable-baselines3 algorithm and policy a config's ``ppo`` block means: PPO with a feed-forward
``MultiInputPolicy``, or, with ``lstm_hidden_size`` > 0, sb3-contrib's RecurrentPPO with a
``MultiInputLstmPolicy`` (the memory lever: obstacles leave the 60° view as the drone passes them).
Training, resuming and loading all ask here, so the choice is made in one place."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from agents.training.train_config import PPOParams

if TYPE_CHECKING:
    from sb3_contrib import RecurrentPPO
    from stable_baselines3 import PPO


def is_recurrent(params: PPOParams) -> bool:
    return params.lstm_hidden_size > 0


def algorithm_class(params: PPOParams) -> type[PPO] | type[RecurrentPPO]:
    """``stable_baselines3.PPO``, or ``sb3_contrib.RecurrentPPO`` for a recurrent policy."""
    # stable-baselines3 (and torch with it) is heavy, sb3-contrib optional: imported only when a model is made.
    if is_recurrent(params):
        from sb3_contrib import RecurrentPPO

        return RecurrentPPO
    from stable_baselines3 import PPO

    return PPO


def policy_alias(params: PPOParams) -> str:
    return "MultiInputLstmPolicy" if is_recurrent(params) else "MultiInputPolicy"


def network_kwargs(params: PPOParams) -> dict[str, Any]:
    """The policy's ``policy_kwargs``: ``net_arch``, ``log_std_init`` and, when recurrent, ``lstm_hidden_size``."""
    network: dict[str, Any] = {"net_arch": list(params.net_arch), "log_std_init": params.log_std_init}
    if is_recurrent(params):
        network["lstm_hidden_size"] = params.lstm_hidden_size
    return network
