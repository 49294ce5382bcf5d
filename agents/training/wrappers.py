"""Gymnasium wrappers used in training and evaluation."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import gymnasium as gym
import numpy as np

from flownav_env.settings import SENSOR_FIELDS, check_setting


class SensorRandomization(gym.Wrapper):
    """Draws the sensor variables of each episode uniformly from ``ranges`` (name → [low, high]).

    Names are FlowNavEnv's sensor settings (:data:`flownav_env.settings.SENSOR_FIELDS`), set through
    ``FlowNavEnv.set_sensor``, which checks them against their ranges. The draw uses the wrapped env's own
    generator, so it is reproducible from ``reset(seed=...)``; the reset frame itself carries no depth, so
    nothing is lost by changing the settings right after it.

    Raises:
        ValueError: a name that is not a sensor setting, or an end outside the setting's range.
    """

    def __init__(self, env: gym.Env, ranges: Mapping[str, Sequence[float]]) -> None:
        super().__init__(env)
        unknown = set(ranges) - set(SENSOR_FIELDS)
        if unknown:
            raise ValueError(f"ranges may only name {', '.join(SENSOR_FIELDS)}, got {sorted(unknown)}")
        self.ranges = {name: tuple(bounds) for name, bounds in ranges.items() if bounds}
        for name, bounds in self.ranges.items():
            for end in bounds:
                check_setting(name, end)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        observation, info = self.env.reset(seed=seed, options=options)
        base = self.env.unwrapped
        rng = np.random.default_rng(int(base.np_random.integers(2**63)))
        drawn = {name: float(rng.uniform(low, high)) for name, (low, high) in self.ranges.items()}
        base.set_sensor(**drawn)
        info = {**info, **{f"sensor_{name}": value for name, value in drawn.items()}}
        return observation, info
