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
# Flies an outside agent without its sandbox (agents.policies.sandbox).
NO_SANDBOX_OPTION = "--no-sandbox"
# Scores a FlowNav agent with a policy file its folder's MANIFEST.sha256 does not list.
UNLISTED_POLICY_OPTION = "--unlisted-policy"
# What an episode row records of how its agent was kept apart from the scorer: an outside agent in its sandbox,
# an outside agent in a plain process of its own (--no-sandbox), or "" for FlowNav's own agents, which run in the
# scoring process.
ISOLATION_SANDBOX = "sandbox"
ISOLATION_PROCESS = "process, no sandbox"


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
    """The memory (GiB of address space) and CPU time (seconds) an outside agent's process may use, and whether
    it runs in the sandbox (:mod:`agents.policies.sandbox`; off only by an explicit ``--no-sandbox``)."""

    memory_gib: float = DEFAULT_AGENT_MEMORY_GIB
    cpu_s: float = DEFAULT_AGENT_CPU_S
    sandboxed: bool = True

    def __post_init__(self) -> None:
        for option, value in ((AGENT_MEMORY_OPTION, self.memory_gib), (AGENT_CPU_OPTION, self.cpu_s)):
            if (
                isinstance(value, bool)
                or not isinstance(value, (int, float))
                or not (math.isfinite(value) and value > 0)
            ):
                raise ValueError(f"{option} must be a finite number > 0, got {value!r}")
        if type(self.sandboxed) is not bool:
            raise ValueError(f"sandboxed must be True or False, got {self.sandboxed!r}")

    @property
    def isolation(self) -> str:
        """How an outside agent flown under these limits is kept apart, as its episode rows record it."""
        return ISOLATION_SANDBOX if self.sandboxed else ISOLATION_PROCESS

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
