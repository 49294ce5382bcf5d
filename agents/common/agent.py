"""What every agent is: something with stable-baselines3's ``predict``. Defined at the bottom so that training
(a teacher start's teacher) names the same interface as the policies and the evaluation above it."""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np


class Agent(Protocol):
    """What the evaluation needs of an agent: stable-baselines3's ``predict``. ``state`` is whatever the agent
    keeps between calls (an LSTM's state, a frame stack; None for a memoryless agent): opaque to its caller,
    who passes back what the last call returned, an ``object`` it does not look into. Taken as Any: each
    agent's ``predict`` takes its own state's type (stable-baselines3's takes its LSTM's arrays)."""

    def predict(
        self,
        observation: dict[str, np.ndarray],
        state: Any = None,
        episode_start: np.ndarray | None = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, object]: ...
