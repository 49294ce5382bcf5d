"""A toy rule that tests declare in one place (:func:`declared_toy_rule`) and then fly, tune and rank as a
shipped rule: the straight flight with a constant sideways command, which checks it got what it asked for."""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from agents.common.agent_table import register_agent, unregister_agent
from agents.policies.reactive import StraightAgent

TOY_RULE = "toy_rule"
# Its whole declaration: the shape of an entry of configs/agents.yaml.
TOY_DECLARATION: Mapping[str, object] = {
    "kind": "rule",
    "sees": "flow",
    "class": "toy_agents:ToyRule",
    "env": {"observe_unresolved": True},
    "search_space": {"heading_gain": [0.5, 3.0, "log"], "sideways": [-0.3, 0.3, "linear"]},
}


@dataclass
class ToyRule(StraightAgent):
    """:class:`StraightAgent` commanding ``sideways`` lateral speed; it refuses an observation without the
    ``unresolved`` key its declaration asks the env for."""

    sideways: float = 0.0
    label: str = "toy"  # not a number: a search space may not name it

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        if "unresolved" not in observation:
            raise ValueError("ToyRule flies on observe_unresolved=True, which its declaration asks for")
        actions, state = super().predict(observation, state, episode_start, deterministic)
        actions = np.array(actions, np.float32)
        actions[..., 0] = self.sideways
        return actions, state


class NotADataclass:
    """A class a declaration may not name: its gains are not dataclass fields."""


@contextmanager
def declared_agent(name: str, declaration: Mapping[str, object]) -> Iterator[str]:
    """``name`` declared as ``declaration`` while the block runs, then taken back."""
    register_agent(name, declaration)
    try:
        yield name
    finally:
        unregister_agent(name)


def declared_toy_rule() -> Iterator[str]:  # the body of a pytest fixture
    """The toy rule declared for a test (``yield from`` it in a fixture)."""
    with declared_agent(TOY_RULE, TOY_DECLARATION) as name:
        yield name
