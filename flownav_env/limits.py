"""Episode time limits that scale with the course, for the registered env ids (``flownav_env.ENV_IDS``)."""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Mapping

import gymnasium as gym

# A submodule: importing it has run flownav_env/__init__, which registers the ids gym.spec looks up.
from flownav_env.settings import EnvSettings


def episode_step_limit(env_id: str, settings: Mapping[str, object]) -> int | None:
    """A time limit that scales with the course: twice the time it takes at the commanded speed, in frames.

    Registered limits assume the default 20 m at 1 m/s and 10 frames/s; a slower flight (a sweep's
    forward-speed levels), a higher frame rate or a longer field would otherwise be cut off before it could
    reach the goal. Never below the registered limit; None (keep it) when none of the three is set.
    """
    if not {"forward_speed", "frame_rate", "field_length"} & set(settings):
        return None
    spec = gym.spec(env_id)
    defaults = {item.name: item.default for item in dataclasses.fields(EnvSettings)}
    merged = {**defaults, **spec.kwargs, **settings}
    speed = max(_number(merged, "forward_speed"), 0.1)
    length = _number(merged, "field_length")
    frame_rate = _number(merged, "frame_rate")
    return max(spec.max_episode_steps or 0, math.ceil(2.0 * length / speed * frame_rate))


def _number(settings: Mapping[str, object], name: str) -> float:
    """The setting ``name`` as a number.

    Raises:
        ValueError: it is not a number (a bool is not one either).
    """
    value = settings[name]
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name} must be a number, got {value!r}")
    return float(value)
