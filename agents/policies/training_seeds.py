"""A learned agent named without a training seed: every shipped training seed, one per episode, in turn.

The benchmark reports a learned agent over its training seeds, flying layout i with seed i mod k
(``flownav evaluate``, the sweep, the leaderboard). ``load_agent("ppo_flow")`` gives the same in Python: an
agent holding each seed's policy that moves to the next seed whenever ``predict`` is told a new episode starts
(``episode_start``, as :func:`~agents.evaluation.episode.run_episode` and SB3's ``evaluate_policy`` pass it).
Its first episode flies the first seed, so episodes flown one after another from a fresh agent on layouts
0, 1, 2, ... fly what ``flownav evaluate`` flies on them.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from agents.policies.base import Agent, AgentWrapper


class TrainingSeedsAgent(AgentWrapper):
    """Several training seeds' policies behind one ``predict``, the next seed at each episode start.

    A caller that never passes ``episode_start`` keeps the first seed throughout. It flies one env at a time:
    a batch of observations is flown by the current seed, which moves on when any of them starts an episode.
    ``agent`` is the policy of the latest call's seed.
    """

    def __init__(self, runs: Sequence[tuple[str, Agent]]) -> None:
        """``runs``: (run name such as ``ppo_flow@0``, its loaded policy), in the order they fly.

        Raises:
            ValueError: no runs.
        """
        if not runs:
            raise ValueError("a TrainingSeedsAgent needs at least one (run name, policy), got none")
        super().__init__(runs[0][1])
        self.runs = list(runs)
        self._current: int | None = None

    @property
    def run_names(self) -> list[str]:
        """The training seeds' run names in flying order: ``ppo_flow@0``, ``ppo_flow@1``, ..."""
        return [name for name, _ in self.runs]

    @property
    def current_run(self) -> str | None:
        """The run flying the current episode; None before the first ``predict``."""
        return None if self._current is None else self.runs[self._current][0]

    def predict(
        self,
        observation: dict[str, np.ndarray],
        state: object = None,
        episode_start: np.ndarray | None = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, object]:
        """The current seed's action; at an episode start (or the first call) the next seed takes over.

        Raises:
            ValueError: the observation lacks a key the policies read (see
                :mod:`agents.policies.observation_keys`).
        """
        starting = episode_start is not None and bool(np.asarray(episode_start).any())
        current = self._current
        if current is None or starting:
            current = 0 if current is None else (current + 1) % len(self.runs)
            state = (
                None  # the previous seed's memory (a frame stack, an LSTM state) means nothing to this one
            )
        self.agent = self.runs[current][1]
        result = super().predict(observation, state, episode_start, deterministic)
        # Only an episode that got its first action moves the turn on: a refused one (an env lacking a key the
        # policies read) leaves the next attempt to the same seed.
        self._current = current
        return result
