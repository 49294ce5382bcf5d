"""The agents built from code (the rules and the planners), made from their declarations in
``configs/agents.yaml`` (or :func:`~agents.common.agent_table.register_agent`): each entry's ``class`` is
imported here, its search space checked against the class's fields, and every name-to-class map, the env
settings an agent asks for and the tunable agents are read from the entries, never written twice.
"""

from __future__ import annotations

import dataclasses
import importlib
from collections.abc import Mapping
from typing import TYPE_CHECKING, Protocol, cast

from agents.common.agent_entry import AgentEntry, EnvValue, SearchRange
from agents.common.agent_table import AGENTS, agents_where, split_agent_name
from agents.policies.base import Agent
from agents.policies.planner import PlannerAgent
from flownav_env.settings import SETTING_NAMES
from flownav_env.settings_check import unknown_setting_message

if TYPE_CHECKING:
    from _typeshed import DataclassInstance

    class RuleAgent(Agent, DataclassInstance, Protocol):
        """An agent that is a dataclass of its gains (a reactive rule, a planner)."""


def built_agents() -> tuple[str, ...]:
    """The declared agents built from a class (rules and planners), in the table's order."""
    return tuple(name for name, entry in AGENTS.items() if entry.class_path)


def tunable_agents() -> tuple[str, ...]:
    """The declared agents with a search space (``flownav tune`` takes them), in the table's order."""
    return agents_where(tunable=True)


def is_built(name: str) -> bool:
    """Whether ``name`` is a declared agent built from a class (a rule or a planner, never with a training
    seed).

    Raises:
        ValueError: as :func:`~agents.common.agent_table.split_agent_name`.
    """
    base, train_seed = split_agent_name(name)
    return train_seed is None and base in AGENTS and bool(AGENTS[base].class_path)


def _built_entry(name: str) -> AgentEntry:
    """The declaration of the agent ``name`` built from a class.

    Raises:
        ValueError: ``name`` is not such an agent (the message lists them).
    """
    entry = AGENTS.get(name)
    if entry is None or not entry.class_path:
        raise ValueError(
            f"agent must be one of {', '.join(built_agents())} (built from a class), got {name!r}"
        )
    return entry


def agent_class(name: str) -> type[RuleAgent]:
    """The class the rule or planner ``name`` is built from: its entry's ``class``, imported.

    Raises:
        ValueError: ``name`` is not built from a class; its class cannot be imported or is not a dataclass; or
            its search space names a gain the class has no field of.
    """
    entry = _built_entry(name)
    module_name, _, class_name = entry.class_path.partition(":")
    try:
        found = getattr(importlib.import_module(module_name), class_name)
    except (ImportError, AttributeError) as error:
        raise ValueError(f"agent {name!r} class {entry.class_path} cannot be imported: {error}") from None
    if not (isinstance(found, type) and dataclasses.is_dataclass(found)):
        raise ValueError(
            f"agent {name!r} class {entry.class_path} must be a dataclass of its gains, got {found!r}"
        )
    fields = [item.name for item in dataclasses.fields(found)]
    unknown = [gain for gain, _ in entry.search_space or () if gain not in fields]
    if unknown:
        raise ValueError(
            f"agent {name!r} search_space names {', '.join(unknown)}, which {class_name} has no field of; its "
            f"fields: {', '.join(fields)}"
        )
    return cast("type[RuleAgent]", found)


def planner_class(name: str) -> type[PlannerAgent]:
    """The class of the planner ``name``.

    Raises:
        ValueError: ``name`` is not a planner (the message lists them), or as :func:`agent_class`.
    """
    planners = agents_where(kind="planner")
    if name not in planners:
        raise ValueError(f"a planner must be one of {', '.join(planners)}, got {name!r}")
    found = agent_class(name)
    if not issubclass(found, PlannerAgent):
        raise ValueError(f"planner {name!r} class {AGENTS[name].class_path} must be a PlannerAgent")
    return found


def rule_agent(name: str, gains: Mapping[str, float]) -> RuleAgent:
    """The rule or planner ``name`` with ``gains`` over its defaults (none for one with ``fixed_gains``).

    Raises:
        ValueError: as :func:`agent_class`.
        TypeError: a gain the class has no field of (the dataclass names it).
    """
    entry = _built_entry(name)
    built = agent_class(name)
    return built() if entry.fixed_gains else built(**gains)


def requested_env_kwargs(name: str) -> dict[str, EnvValue]:
    """The env settings the rule or planner ``name`` asks for beyond the env's defaults (its entry's ``env``).

    Raises:
        ValueError: ``name`` is not built from a class, or asks for a setting the env does not have.
    """
    settings = dict(_built_entry(name).env)
    for setting in settings:
        if setting not in SETTING_NAMES:
            raise ValueError(f"agent {name!r} env: {unknown_setting_message(setting)}")
    return settings


def search_space(name: str) -> dict[str, SearchRange]:
    """The tunable agent ``name``'s search space, gain -> (low, high, log scale), in the order it is drawn.

    Raises:
        ValueError: ``name`` has no search space (the message lists those that have), or as :func:`agent_class`.
    """
    entry = AGENTS.get(name)
    if entry is None or entry.search_space is None:
        raise ValueError(f"agent must be one of {', '.join(tunable_agents())} (tunable), got {name!r}")
    agent_class(name)  # its gains are its class's fields
    return dict(entry.search_space)
