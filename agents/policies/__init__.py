"""The agents behind one ``predict`` interface: reactive rules and learned (PPO) policies."""

from agents.policies.base import AGENT_NAMES, LEARNED_AGENTS, REACTIVE_AGENTS, Agent
from agents.policies.learned import agent_env_kwargs, load_agent, policy_file
from agents.policies.reactive import BeeAgent, StraightAgent, bin_nearness, sector_nearness

__all__ = [
    "AGENT_NAMES",
    "LEARNED_AGENTS",
    "REACTIVE_AGENTS",
    "Agent",
    "BeeAgent",
    "StraightAgent",
    "agent_env_kwargs",
    "bin_nearness",
    "load_agent",
    "policy_file",
    "sector_nearness",
]
