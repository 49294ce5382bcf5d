"""Which env setting gives which optional observation key, and the check that a loaded policy gets every key it
reads.

A policy trained with, say, ``observe_approach=True`` reads the ``approach`` key. Flown on an env made without
that setting, stable-baselines3 fails deep inside ``predict`` with a bare ``KeyError: 'approach'``; the check
here fails first, with one line naming the key, the setting that gives it and the config the policy was
trained with.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path

import numpy as np

from agents.policies.base import Agent, AgentWrapper

# The env's optional observation keys, each with the FlowNav setting that adds it (flownav_env.observation's
# observation_space): the env's documentation names them per key, but nothing there maps one to the other.
OBSERVATION_KEY_SETTINGS = {
    "unresolved": "observe_unresolved",
    "point_counts": "observe_counts",
    "nearness": "observe_nearness",
    "approach": "observe_approach",
}


def missing_keys_message(missing: Iterable[str], policy: Path, config: Path | None) -> str:
    """The one-line error for a ``policy`` that reads the observation keys ``missing``, which an env does not
    give: the keys, the env settings that give them and where the settings it was trained with are."""
    missing = list(missing)
    keys = ", ".join(repr(key) for key in missing)
    noun = "key" if len(missing) == 1 else "keys"
    settings = [f"{OBSERVATION_KEY_SETTINGS[key]}=True" for key in missing if key in OBSERVATION_KEY_SETTINGS]
    remedy = f": make the env with {', '.join(settings)}" if settings else ""
    if config is None:
        trained = "no training config beside it says which env it was trained with"
    else:
        trained = (
            f"the settings it was trained with are in {config}; "
            f"agents.policies.load_policy({str(policy)!r}).make_env() makes that env"
        )
    return (
        f"policy {policy} reads observation {noun} {keys}, which this env does not give{remedy} ({trained})"
    )


class ObservationKeyCheck:
    """Raises the :func:`missing_keys_message` ValueError for an observation that lacks a key the policy reads."""

    def __init__(self, keys: Iterable[str], policy: Path, config: Path | None) -> None:
        self.keys = tuple(keys)
        self.policy = Path(policy)
        self.config = config

    def __call__(self, observation: object) -> None:
        """Check ``observation`` (a dict, batched or not).

        Raises:
            ValueError: it lacks keys the policy reads; the message names them and the settings giving them.
        """
        if not isinstance(observation, Mapping):
            return  # not a FlowNav observation: the policy's own checks speak
        missing = [key for key in self.keys if key not in observation]
        if missing:
            raise ValueError(missing_keys_message(missing, self.policy, self.config))


class CheckedPolicy(AgentWrapper):
    """A loaded policy whose ``predict`` first checks that the observation has every key the policy reads."""

    def __init__(self, policy: Agent, check: ObservationKeyCheck) -> None:
        super().__init__(policy)
        self.check = check

    def observe(self, observation: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """The observation, after :class:`ObservationKeyCheck`.

        Raises:
            ValueError: the observation lacks a key the policy reads.
        """
        self.check(observation)
        return observation
