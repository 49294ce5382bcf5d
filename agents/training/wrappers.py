"""Gymnasium wrappers used in training and evaluation."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import gymnasium as gym
import numpy as np

from flownav_env.env import FlowNavEnv
from flownav_env.settings import COURSE_FIELDS, SENSOR_FIELDS
from flownav_env.settings_check import check_setting


class SensorRandomization(gym.Wrapper):
    """Draws the sensor and course variables of each episode uniformly from ``ranges`` (name → [low, high]).

    Sensor names (:data:`flownav_env.settings.SENSOR_FIELDS`) are set through ``FlowNavEnv.set_sensor`` right
    after the reset, drawn from the wrapped env's own generator, so they are reproducible from
    ``reset(seed=...)``; the reset frame carries no depth, so nothing is lost by changing them after it. Course
    names (``forward_speed``, ``obstacle_density``: :data:`~flownav_env.settings.COURSE_FIELDS`) shape the
    layout and the start, so they are drawn before each reset, from this wrapper's generator (seeded by the
    first ``reset(seed=...)``), and set through ``FlowNavEnv.set_course``. Both setters check the ranges.

    Raises:
        ValueError: ``env`` is not a FlowNavEnv (or a wrapper of one), a name that is neither, or an end outside
            the setting's range.
    """

    def __init__(self, env: gym.Env, ranges: Mapping[str, Sequence[float]]) -> None:
        super().__init__(env)
        base = env.unwrapped
        if not isinstance(base, FlowNavEnv):
            raise ValueError(
                f"SensorRandomization wraps a FlowNavEnv (or a wrapper of one), got {type(base).__name__}"
            )
        self.flownav = base
        allowed = SENSOR_FIELDS + COURSE_FIELDS
        unknown = set(ranges) - set(allowed)
        if unknown:
            raise ValueError(f"ranges may only name {', '.join(allowed)}, got {sorted(unknown)}")
        ranges = {name: tuple(bounds) for name, bounds in ranges.items() if bounds}
        for name, bounds in ranges.items():
            for end in bounds:
                check_setting(name, end)
        self.ranges = {name: bounds for name, bounds in ranges.items() if name in SENSOR_FIELDS}
        self.course_ranges = {name: bounds for name, bounds in ranges.items() if name in COURSE_FIELDS}
        self._course_rng: np.random.Generator | None = None

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        if self.course_ranges:
            if seed is not None or self._course_rng is None:
                self._course_rng = np.random.default_rng(seed)
            rng = self._course_rng
            course = {name: float(rng.uniform(low, high)) for name, (low, high) in self.course_ranges.items()}
            self.flownav.set_course(**course)
        observation, info = self.env.reset(seed=seed, options=options)
        rng = np.random.default_rng(int(self.flownav.np_random.integers(2**63)))
        drawn = {name: float(rng.uniform(low, high)) for name, (low, high) in self.ranges.items()}
        self.flownav.set_sensor(**drawn)
        if self.course_ranges:
            drawn = {**drawn, **course}
        info = {**info, **{f"sensor_{name}": value for name, value in drawn.items()}}
        return observation, info
