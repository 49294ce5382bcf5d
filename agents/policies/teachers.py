"""Teachers for a run's teacher start (``imitation.teacher`` in a training config): which agents may teach, and
the check that the run's env observes everything the teacher reads."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from agents.policies.base import REACTIVE_AGENTS
from agents.policies.learned import agent_env_kwargs, load_agent


def check_teacher(name: str, env: Mapping[str, Any], source: str) -> None:
    """Check that ``name`` can teach a run whose env is made with ``env`` (a config's ``env`` section).

    Raises:
        ValueError: ``name`` is not a reactive agent (a teacher acts from the observation alone, so learned
            policies, which need their own env settings, are not offered), or the env lacks a setting the
            teacher reads; the message names the key and the config file ``source``.
    """
    if name not in REACTIVE_AGENTS:
        raise ValueError(
            f"{source}: key 'imitation.teacher' must be one of {', '.join(REACTIVE_AGENTS)}, got {name!r}"
        )
    for setting, value in agent_env_kwargs(name).items():
        if env.get(setting) != value:
            raise ValueError(
                f"{source}: the teacher {name!r} reads what the env setting {setting}={value!r} gives; add it "
                f"to the config's 'env' section (it has {setting}={env.get(setting)!r})"
            )


def make_teacher(name: str) -> Any:
    """The teacher agent ``name``, with its shipped gains (a module-level function, so a training job that
    carries it pickles)."""
    return load_agent(name)
