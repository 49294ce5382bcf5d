"""A policy trained on stacked frames (``frame_stack`` in its training config), flown one env at a time.

Training stacks observations with stable-baselines3's ``VecFrameStack``. Evaluation flies single envs through
``predict``, so the agent keeps the stack itself, as its ``state``: the same ``StackedObservations`` that
``VecFrameStack`` uses, reset at ``episode_start`` (zeros, then the first frame last), so a policy sees in
evaluation exactly the stacks it saw in training.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from gymnasium import spaces


def stacked_space(space: spaces.Space, frame_stack: int) -> spaces.Space:
    """The observation space a ``VecFrameStack`` of ``frame_stack`` frames gives for ``space``."""
    from stable_baselines3.common.vec_env.stacked_observations import StackedObservations

    return StackedObservations(1, frame_stack, space).stacked_observation_space


class FrameStackedAgent:
    """SB3's ``predict`` over the last ``frame_stack`` observations of one env, the stack kept as ``state``;
    ``check`` (if given) sees each observation first, before a missing key fails inside the stack."""

    def __init__(
        self,
        policy: Any,
        frame_stack: int,
        observation_space: spaces.Dict,
        check: Callable[[Any], None] | None = None,
    ) -> None:
        self.policy = policy
        self.frame_stack = frame_stack
        self.observation_space = observation_space
        self.check = check

    def predict(
        self,
        observation: dict[str, np.ndarray],
        state: Any = None,
        episode_start: np.ndarray | None = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Any]:
        from stable_baselines3.common.vec_env.stacked_observations import StackedObservations

        if self.check is not None:
            self.check(observation)
        batched = {key: np.asarray(value)[None] for key, value in observation.items()}
        starting = state is None or (episode_start is not None and bool(np.asarray(episode_start).any()))
        if starting:
            state = StackedObservations(1, self.frame_stack, self.observation_space)
            stacked = state.reset(batched)
        else:
            stacked, _ = state.update(batched, np.zeros(1, bool), [{}])
        action, _ = self.policy.predict(stacked, deterministic=deterministic)
        return action[0], state
