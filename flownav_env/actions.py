"""The env's action: its space, and the check every action passes before the drone flies it."""

from __future__ import annotations

import numpy as np
from gymnasium import spaces

# Lateral velocity, vertical velocity and yaw rate (FlowNavEnv's Action Space table).
ACTION_SHAPE = (3,)


def action_space() -> spaces.Box:
    """The action space: ``Box(-1, 1, (3,), float32)``."""
    return spaces.Box(-1.0, 1.0, ACTION_SHAPE, np.float32)


def checked_action(action: object) -> np.ndarray:
    """``action`` as float64 values clipped to [-1, 1], once it is what the action space declares.

    Runs on every step, so it stays a shape comparison and one finiteness test.

    Args:
        action: An array of shape (3,), or a plain sequence of 3 numbers.

    Returns:
        The (3,) float64 action, each value clipped to [-1, 1].

    Raises:
        ValueError: ``action`` is not numbers of shape (3,) (a (1, 3) batch included), or holds NaN or ±inf
            (clipping would turn an infinite value into a full command unnoticed).
    """
    try:
        values = np.asarray(action, np.float64)
    except (TypeError, ValueError) as error:
        raise ValueError(
            f"action must be numbers of shape {ACTION_SHAPE}, got {type(action).__name__}: {error}"
        ) from None
    if values.shape != ACTION_SHAPE:
        raise ValueError(f"action must have shape {ACTION_SHAPE}, got shape {values.shape}")
    if not np.isfinite(values).all():
        raise ValueError(f"action must be finite, got {values!r}")
    return np.clip(values, -1.0, 1.0)
