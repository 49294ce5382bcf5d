"""The agents behind one ``predict`` interface: reactive rules and learned (PPO) policies."""

from agents.policies.base import (
    AGENT_NAMES,
    HISTORY_AGENTS,
    LEARNED_AGENTS,
    PRIVILEGED_AGENTS,
    REACTIVE_AGENTS,
    Agent,
    is_learned,
    seeded_agent_name,
    split_agent_name,
)
from agents.policies.learned import (
    POLICY_OPTION_HELP,
    TRUST_PICKLE_HELP,
    LoadedPolicy,
    agent_env_kwargs,
    agent_parameters,
    default_runs,
    is_privileged,
    load_agent,
    load_policy,
    policy_file,
    runs_to_fly,
    shipped_seed_runs,
    single_policy_file,
    trained_on,
    trained_seeds,
)
from agents.policies.loading import UnverifiedPolicyWarning
from agents.policies.observation_keys import OBSERVATION_KEY_SETTINGS
from agents.policies.reactive import BeeAgent, StraightAgent, bin_nearness, sector_nearness
from agents.policies.robust import BeeRobustAgent, BeeTTCAgent, VFHAgent, quantile_nearness
from agents.policies.training_seeds import TrainingSeedsAgent

__all__ = [
    "AGENT_NAMES",
    "HISTORY_AGENTS",
    "LEARNED_AGENTS",
    "OBSERVATION_KEY_SETTINGS",
    "POLICY_OPTION_HELP",
    "PRIVILEGED_AGENTS",
    "REACTIVE_AGENTS",
    "TRUST_PICKLE_HELP",
    "Agent",
    "BeeAgent",
    "BeeRobustAgent",
    "BeeTTCAgent",
    "LoadedPolicy",
    "StraightAgent",
    "TrainingSeedsAgent",
    "UnverifiedPolicyWarning",
    "VFHAgent",
    "agent_env_kwargs",
    "agent_parameters",
    "bin_nearness",
    "default_runs",
    "is_learned",
    "is_privileged",
    "load_agent",
    "load_policy",
    "policy_file",
    "quantile_nearness",
    "runs_to_fly",
    "sector_nearness",
    "seeded_agent_name",
    "shipped_seed_runs",
    "single_policy_file",
    "split_agent_name",
    "trained_on",
    "trained_seeds",
]
