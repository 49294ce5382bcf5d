"""Gymnasium wrappers used in training and evaluation."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import gymnasium as gym
import numpy as np


class SensorRandomization(gym.Wrapper):
    """Draws the sensor variables of each episode uniformly from ``ranges`` (name → [low, high]).

    Names are FlowNavEnv sensor attributes read every step: ``rotation_error``, ``translation_error``,
    ``attitude_jitter_deg`` and ``brightness``. The draw uses the wrapped env's own generator, so it is
    reproducible from ``reset(seed=...)``; the reset frame itself carries no depth, so nothing is lost by
    changing the settings right after it.
    """

    SENSOR_VARIABLES = ("rotation_error", "translation_error", "attitude_jitter_deg", "brightness")

    def __init__(self, env: gym.Env, ranges: Mapping[str, Sequence[float]]) -> None:
        super().__init__(env)
        unknown = set(ranges) - set(self.SENSOR_VARIABLES)
        if unknown:
            raise ValueError(
                f"ranges may only name {', '.join(self.SENSOR_VARIABLES)}, got {sorted(unknown)}"
            )
        self.ranges = {name: tuple(bounds) for name, bounds in ranges.items() if bounds}

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        observation, info = self.env.reset(seed=seed, options=options)
        base = self.env.unwrapped
        rng = np.random.default_rng(int(base.np_random.integers(2**63)))
        for name, (low, high) in self.ranges.items():
            setattr(base, name, float(rng.uniform(low, high)))
        base.physics.set_brightness(base.brightness)
        info = {**info, **{f"sensor_{name}": getattr(base, name) for name in self.ranges}}
        return observation, info
