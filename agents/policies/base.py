"""What every agent is: something with stable-baselines3's ``predict`` (:class:`Agent`, declared in the bottom
layer for training's teachers too), the base of agents that wrap another, and the names the benchmark knows by
kind (read from ``configs/agents.yaml`` by :mod:`agents.common.agent_table`)."""

from __future__ import annotations

import inspect
from typing import cast

import numpy as np

from agents.common.agent import Agent  # the agents' one interface, named from here above the bottom layer
from agents.common.agent_table import (
    AGENT_TABLE,
    AGENTS,
    TRAIN_SEED_MARK,
    agents_where,
    base_agent_name,
    is_learned,
    is_per_tier,
    seeded_agent_name,
    split_agent_name,
)

# The names by kind, in configs/agents.yaml's order (what each agent is, and why, is written there).
REACTIVE_AGENTS = agents_where(kind="rule")
LEARNED_AGENTS = agents_where(kind="learned")
PLANNERS = agents_where(kind="planner")
AGENT_NAMES = tuple(AGENTS)
# Learned agents trained across the tiers, flown on the suite only: the clean tier's history table predates them.
SUITE_ONLY_AGENTS = tuple(entry.name for entry in AGENT_TABLE if entry.suite_only)
# The agents of the clean tier's history table: every agent but the planners, which are flown only on the suite,
# as each tier's bound, and the suite-only learned agents. (The demo flies every rule and every shipped policy.)
HISTORY_AGENTS = REACTIVE_AGENTS + tuple(agent for agent in LEARNED_AGENTS if agent not in SUITE_ONLY_AGENTS)
# The agents that read what a tier's sensor does not give: references, listed apart in every table, never ranked.
PRIVILEGED_AGENTS = agents_where(privileged=True)
# Agents retired from the suite, each with why; the suite's report lists each one's flown seeds per tier.
RETIRED_AGENTS = {entry.name: entry.retired for entry in AGENT_TABLE if entry.retired}
# The agents the suite flies and ranks (with its references): every agent but the retired ones.
SUITE_AGENTS = tuple(agent for agent in AGENT_NAMES if agent not in RETIRED_AGENTS)
# Per suite version, the agents of the suite it does not fly, each with why (``not_flown_on`` in the table).
NOT_FLOWN_ON: dict[str, dict[str, str]] = {
    version: {entry.name: why for entry in AGENT_TABLE for v, why in entry.not_flown_on if v == version}
    for version in sorted({v for entry in AGENT_TABLE for v, _ in entry.not_flown_on})
}

__all__ = [
    "AGENT_NAMES",
    "HISTORY_AGENTS",
    "LEARNED_AGENTS",
    "NOT_FLOWN_ON",
    "PLANNERS",
    "PRIVILEGED_AGENTS",
    "REACTIVE_AGENTS",
    "RETIRED_AGENTS",
    "SUITE_AGENTS",
    "SUITE_ONLY_AGENTS",
    "TRAIN_SEED_MARK",
    "Agent",
    "AgentWrapper",
    "base_agent_name",
    "check_flown_on",
    "check_not_retired",
    "is_learned",
    "is_per_tier",
    "seeded_agent_name",
    "split_agent_name",
    "suite_agents_of",
]


def check_not_retired(name: str) -> str:
    """``name`` itself, unless it names an agent retired from the suite (or one of its training seeds).

    Raises:
        ValueError: a retired agent, with why it was retired.
    """
    base = base_agent_name(name)
    if base in RETIRED_AGENTS:
        raise ValueError(
            f"{name!r} is retired from the suite ({RETIRED_AGENTS[base]}); fly it with flownav evaluate, or "
            "name an agent of the suite"
        )
    return name


def suite_agents_of(version: str) -> tuple[str, ...]:
    """The agents suite ``version`` flies, in the table's order: :data:`SUITE_AGENTS` but those not flown on it."""
    skipped = NOT_FLOWN_ON.get(version, {})
    return tuple(agent for agent in SUITE_AGENTS if agent not in skipped)


def check_flown_on(name: str, version: str) -> str:
    """``name`` itself, unless it names an agent (or one of its training seeds) that suite ``version`` does not
    fly.

    Raises:
        ValueError: such an agent, with why, and the versions that do fly it.
    """
    base = base_agent_name(name)
    why = NOT_FLOWN_ON.get(version, {}).get(base)
    if why is not None:
        raise ValueError(
            f"{name!r} is not flown on suite v{version} ({why}); name an agent of suite v{version}, or fly it on "
            "another suite version with --suite-version"
        )
    return name


class AgentWrapper:
    """An agent that flies another one, ``agent``: ``predict`` passes each call through, on what
    :meth:`observe` makes of the observation. A wrapper overrides :meth:`observe` to check or convert the
    observation, and ``predict`` itself (calling this one) to change the call around it.
    """

    def __init__(self, agent: Agent) -> None:
        self.agent = agent

    def predict(
        self,
        observation: dict[str, np.ndarray],
        state: object = None,
        episode_start: np.ndarray | None = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, object]:
        """``agent``'s ``predict`` on :meth:`observe`'s view of ``observation``."""
        return self.agent.predict(
            self.observe(observation), state=state, episode_start=episode_start, deterministic=deterministic
        )

    def observe(self, observation: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """What ``agent`` is given of ``observation``: the observation itself, unless a wrapper checks or
        converts it here (raising a ValueError for one it refuses)."""
        return observation


def predict_location(agent: Agent) -> str | None:
    """Where the ``predict`` that ``agent`` flies with is written, ``path/to/file.py:LINE`` (the innermost agent
    under any :class:`AgentWrapper`), for an error about what it returned; None where Python cannot say."""
    while isinstance(agent, AgentWrapper):
        agent = agent.agent
    declared = getattr(agent, "declared_predict_location", None)
    if callable(declared):  # an agent in another process says where its predict is written
        return cast("str | None", declared())
    try:
        method = inspect.unwrap(type(agent).predict)
        return f"{inspect.getsourcefile(method)}:{inspect.getsourcelines(method)[1]}"
    except (AttributeError, TypeError, OSError):
        return None
