"""The agent wrapper base: ``predict`` passes through, on what ``observe`` makes of the observation."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from agents.policies.base import AgentWrapper


class _Recording:
    def __init__(self) -> None:
        self.calls: list[tuple[Any, ...]] = []

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        self.calls.append((observation, state, episode_start, deterministic))
        return np.zeros(3), "memory"


class _Refusing(AgentWrapper):
    def observe(self, observation: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        if "state" not in observation:
            raise ValueError("no state")
        return {"state": observation["state"] * 2}


def test_predict_passes_every_argument_through_and_returns_the_agents_result() -> None:
    inner = _Recording()
    observation = {"state": np.ones(7)}
    start = np.array([True])
    action, state = AgentWrapper(inner).predict(observation, "before", start, deterministic=False)
    assert np.array_equal(action, np.zeros(3)) and state == "memory"
    assert inner.calls == [(observation, "before", start, False)]


def test_observe_checks_or_converts_what_the_agent_sees() -> None:
    inner = _Recording()
    wrapper = _Refusing(inner)
    wrapper.predict({"state": np.ones(2)})
    assert np.array_equal(inner.calls[0][0]["state"], np.full(2, 2.0))
    with pytest.raises(ValueError, match="no state"):
        wrapper.predict({})
    assert len(inner.calls) == 1
