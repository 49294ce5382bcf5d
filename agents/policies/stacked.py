"""A policy trained on stacked frames (``frame_stack`` in its training config), flown one env at a time.

Training stacks observations with stable-baselines3's ``VecFrameStack``. Evaluation flies single envs through
``predict``, so the agent keeps the stack itself, as its ``state``: the same ``StackedObservations`` that
``VecFrameStack`` uses, reset at ``episode_start`` (zeros, then the first frame last), so a policy sees in
evaluation exactly the stacks it saw in training.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, cast

import numpy as np
from gymnasium import spaces

from agents.policies.base import Agent, AgentWrapper

if TYPE_CHECKING:
    from stable_baselines3.common.vec_env.stacked_observations import StackedObservations


def stacked_space(space: spaces.Dict, frame_stack: int) -> spaces.Dict:
    """The observation space a ``VecFrameStack`` of ``frame_stack`` frames gives for ``space``."""
    # stable-baselines3 (and torch with it) is heavy: imported only when a stacked policy loads.
    from stable_baselines3.common.vec_env.stacked_observations import StackedObservations

    stacked = StackedObservations(1, frame_stack, space).stacked_observation_space
    assert isinstance(stacked, spaces.Dict)  # a stack of named arrays is named arrays
    return stacked


class FrameStackedAgent(AgentWrapper):
    """SB3's ``predict`` over the last ``frame_stack`` observations of one env, the stack kept as ``state``;
    ``check`` (if given) sees each observation first, before a missing key fails inside the stack."""

    def __init__(
        self,
        policy: Agent,
        frame_stack: int,
        observation_space: spaces.Dict,
        check: Callable[[object], None] | None = None,
    ) -> None:
        super().__init__(policy)
        self.frame_stack = frame_stack
        self.observation_space = observation_space
        self.check = check

    def observe(self, observation: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """The observation, after ``check``."""
        if self.check is not None:
            self.check(observation)
        return observation

    def predict(
        self,
        observation: dict[str, np.ndarray],
        state: object = None,
        episode_start: np.ndarray | None = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, object]:
        """The policy's action for the stack ending with ``observation``; the stack is the returned state."""
        # stable-baselines3 (and torch with it) is heavy: imported only when a stacked policy flies.
        from stable_baselines3.common.vec_env.stacked_observations import StackedObservations

        observation = self.observe(observation)
        batched = {key: np.asarray(value)[None] for key, value in observation.items()}
        stack: StackedObservations[dict[str, np.ndarray]]
        if state is None or (episode_start is not None and bool(np.asarray(episode_start).any())):
            stack = StackedObservations(1, self.frame_stack, self.observation_space)
            stacked = stack.reset(batched)
        else:
            stack = cast("StackedObservations[dict[str, np.ndarray]]", state)  # what the last call returned
            stacked, _ = stack.update(batched, np.zeros(1, bool), [{}])
        action, _ = self.agent.predict(stacked, deterministic=deterministic)
        return action[0], stack
