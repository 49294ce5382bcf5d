"""A time limit on each ``predict`` call of an agent written outside FlowNav.

An outside agent whose ``predict`` never returns would otherwise hang its run for good, holding its claim on
the episode. The limit is a ``SIGALRM`` timer (``signal.setitimer``) armed around each call in the process that
flies the episode: its handler raises in the middle of whatever the agent runs, a pure-Python loop or a
``time.sleep`` alike. Signals reach only a process's main thread, where pool workers and a one-worker run fly;
called from another thread the agent runs without a limit rather than not at all.
"""

from __future__ import annotations

import signal
import threading
from types import FrameType
from typing import Any

import numpy as np

from agents.policies import Agent
from agents.policies.base import AgentWrapper

# What an outside agent's predict may take by default; generous (a policy answers in milliseconds) so only a
# predict that hangs meets it.
DEFAULT_STEP_TIMEOUT_S = 30.0
STEP_TIMEOUT_OPTION = "--step-timeout"


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


class _OutOfTime(BaseException):
    """What the timer raises inside the agent's code: not an Exception, so that no ``except Exception`` in the
    agent or in the wrappers around it turns it into something else; :class:`TimeLimitedAgent` turns it into
    :class:`PredictTimeout`."""


def _out_of_time(signum: int, frame: FrameType | None) -> None:
    raise _OutOfTime


class TimeLimitedAgent(AgentWrapper):
    """``agent`` whose every ``predict`` call is cut off after ``limit_s`` seconds with :class:`PredictTimeout`
    (message: ``message``)."""

    def __init__(self, agent: Agent, limit_s: float, message: str) -> None:
        super().__init__(agent)
        self.limit_s = limit_s
        self.message = message

    def predict(
        self,
        observation: dict[str, np.ndarray],
        state: Any = None,
        episode_start: np.ndarray | None = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Any]:
        """The agent's ``predict``, interrupted past the limit.

        Raises:
            PredictTimeout: the call ran past ``limit_s``.
        """
        if threading.current_thread() is not threading.main_thread():
            return super().predict(observation, state, episode_start, deterministic)
        previous = signal.signal(signal.SIGALRM, _out_of_time)
        signal.setitimer(signal.ITIMER_REAL, self.limit_s)
        try:
            try:
                result = super().predict(observation, state, episode_start, deterministic)
            finally:
                signal.setitimer(signal.ITIMER_REAL, 0)
        except _OutOfTime:  # also when the timer fired just as predict returned: it did reach the limit
            raise PredictTimeout(self.message) from None
        finally:
            signal.signal(signal.SIGALRM, previous)
        return result
