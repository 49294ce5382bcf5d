"""What an outside agent's process may use: the time a ``predict`` call may take, its memory and its CPU time;
the options that set them, and the lines said when one runs out."""

from __future__ import annotations

import math
from dataclasses import dataclass

# What an outside agent's predict may take by default; generous (a policy answers in milliseconds) so only a
# predict that hangs meets it.
DEFAULT_STEP_TIMEOUT_S = 30.0
STEP_TIMEOUT_OPTION = "--step-timeout"
# The address space an outside agent's process may map (RLIMIT_AS): torch alone maps about 1 GiB.
DEFAULT_AGENT_MEMORY_GIB = 2.0
AGENT_MEMORY_OPTION = "--agent-memory"
# The CPU time an outside agent's process may use over its life (RLIMIT_CPU); it lives as long as the run.
DEFAULT_AGENT_CPU_S = 3600.0
AGENT_CPU_OPTION = "--agent-cpu"


class PredictTimeout(ValueError):
    """An agent's ``predict`` ran past its limit; the message names the agent, the episode and the limit. A
    ValueError: the agent is the user's to fix, and ``flownav`` prints it as one line."""


def timeout_message(agent: str, episode: str, limit_s: float) -> str:
    """The one line that ends a run whose agent's ``predict`` ran past ``limit_s`` in ``episode``."""
    return (
        f"agent {agent} did not return from predict within {limit_s:g} s ({STEP_TIMEOUT_OPTION}) in {episode}; "
        f"the run stopped and that episode is not recorded: fix the agent, or raise {STEP_TIMEOUT_OPTION} "
        "(0 = no limit)"
    )


@dataclass(frozen=True)
class AgentLimits:
    """The memory (GiB of address space) and CPU time (seconds) an outside agent's process may use."""

    memory_gib: float = DEFAULT_AGENT_MEMORY_GIB
    cpu_s: float = DEFAULT_AGENT_CPU_S

    def __post_init__(self) -> None:
        for option, value in ((AGENT_MEMORY_OPTION, self.memory_gib), (AGENT_CPU_OPTION, self.cpu_s)):
            if (
                isinstance(value, bool)
                or not isinstance(value, (int, float))
                or not (math.isfinite(value) and value > 0)
            ):
                raise ValueError(f"{option} must be a finite number > 0, got {value!r}")

    @property
    def memory_bytes(self) -> int:
        """The address-space limit in bytes."""
        return int(self.memory_gib * 2**30)


def check_step_timeout(step_timeout_s: float) -> None:
    """Refuse a step timeout that is not a number of seconds >= 0.

    Raises:
        ValueError: one line naming the option and the value.
    """
    if not (math.isfinite(step_timeout_s) and step_timeout_s >= 0):
        raise ValueError(
            f"{STEP_TIMEOUT_OPTION} must be a number of seconds >= 0 (0 = no limit), got {step_timeout_s!r}"
        )
