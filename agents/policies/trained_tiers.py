"""Which of the suite's tiers a learned agent trained on, read from its training config: a tier counts when every
course and sensor setting it flies was flown in training, fixed or inside a range drawn per episode.

A policy may train on one tier (``FlowNav-v0`` with its defaults is the clean tier) or across several (ranges
that span them). What it is shown (observation keys, true depths) is not the tier's business, so those
settings are not compared: the tier says which task was learned, the privileged flag what was seen.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from pathlib import Path

from agents.common.seeds import TIER_TRAINING_SEEDS, TIER_VALIDATION_SEEDS
from agents.common.yaml_config import load_config
from agents.policies.base import is_learned
from agents.policies.learned import policy_file
from agents.training.train_config import TrainConfig
from flownav_env.settings import EnvSettings
from flownav_env.tiers import (
    AGENT_OBSERVATION_SETTINGS,
    PRIVILEGED_SETTING_VALUES,
    SUITE_VERSION,
    TIER_NAMES,
    tier,
    tier_of_env_id,
    tier_value,
)


@dataclasses.dataclass(frozen=True)
class TierSeedSplit:
    """The layouts a policy for one suite tier trains on, and those that decide anything about it."""

    tier: str
    training: range
    validation: range


def tier_seed_split(name: str) -> TierSeedSplit:
    """The training and validation layouts of a suite tier (``agents.common.seeds``), disjoint from every test
    layout; a policy across tiers draws from the same two ranges on each tier.

    Raises:
        ValueError: ``name`` is not a suite tier.
    """
    tier(name)  # one line naming the tiers for an unknown one
    return TierSeedSplit(name, TIER_TRAINING_SEEDS, TIER_VALIDATION_SEEDS)


# Settings that change what an agent is shown, not the task it flies.
_SHOWN_SETTINGS = frozenset(AGENT_OBSERVATION_SETTINGS) | frozenset(PRIVILEGED_SETTING_VALUES)
# Ranges are written to a few significant digits in configs (0.004427 for a derived σ): a tier value within
# this relative distance of a range's end counts as inside it.
_RELATIVE_TOLERANCE = 1e-3


def _flown(value: object, fixed: object, bounds: Sequence[float] | None) -> bool:
    """Whether training flew ``value``: inside the drawn ``bounds`` if the setting was drawn, else equal to the
    ``fixed`` value it trained with."""
    if bounds:
        low, high = float(min(bounds)), float(max(bounds))
        slack = _RELATIVE_TOLERANCE * max(abs(low), abs(high), 1e-12)
        return isinstance(value, (int, float)) and low - slack <= float(value) <= high + slack
    if isinstance(value, float) or isinstance(fixed, float):
        return (
            isinstance(value, (int, float))
            and isinstance(fixed, (int, float))
            and math.isclose(float(value), float(fixed), rel_tol=_RELATIVE_TOLERANCE, abs_tol=1e-12)
        )
    return value == fixed


def tiers_covered(
    env: Mapping[str, object],
    randomize: Mapping[str, Sequence[float] | None],
    version: str = SUITE_VERSION,
) -> tuple[str, ...]:
    """The tiers of suite ``version`` (suite order) whose every task setting a training run with fixed settings
    ``env`` and per-episode ranges ``randomize`` flew. Settings that only shape the observation are not compared.

    Raises:
        ValueError: ``env`` or ``randomize`` names something that is not a FlowNav env setting.
    """
    known = {item.name for item in dataclasses.fields(EnvSettings)}
    unknown = sorted((set(env) | {key for key, bounds in randomize.items() if bounds}) - known)
    if unknown:
        raise ValueError(
            f"not FlowNav env settings: {', '.join(unknown)}; settings are {', '.join(sorted(known))}"
        )
    defaults = {item.name: item.default for item in dataclasses.fields(EnvSettings)}
    compared = sorted(
        ({key for key, bounds in randomize.items() if bounds} | set(env) | _tier_settings(version))
        - _SHOWN_SETTINGS
    )
    return tuple(
        name
        for name in TIER_NAMES
        if all(
            _flown(tier_value(name, key, version), env.get(key, defaults[key]), randomize.get(key))
            for key in compared
        )
    )


def _tier_settings(version: str) -> set[str]:
    """Every setting some tier of suite ``version`` fixes away from the env's defaults."""
    return {key for name in TIER_NAMES for key in tier(name, version).settings}


def config_tiers(config_path: str | Path, version: str = SUITE_VERSION) -> tuple[str, ...]:
    """The tiers of suite ``version`` the training config at ``config_path`` (a policy's ``.yaml``) trained on.
    Its env id is a tier's of any version (whose settings it starts from, under its own ``env``); any other id
    gives none."""
    config = load_config(config_path, TrainConfig)
    found = tier_of_env_id(config.env_id)
    if found is None:
        return ()
    env = {**found[1].settings, **dict(config.env)}
    return tiers_covered(env, config.randomize.ranges(), version)


def agent_tiers(name: str, version: str = SUITE_VERSION) -> tuple[str, ...]:
    """The tiers of suite ``version`` the shipped learned agent ``name`` trained on, from the training config
    beside its policy; none for an agent that did not learn or whose policy has no config beside it."""
    if not is_learned(name):
        return ()
    config_path = policy_file(name).with_suffix(".yaml")
    return config_tiers(config_path, version) if config_path.is_file() else ()
