"""What every agent is: something with stable-baselines3's ``predict``, and the names the benchmark knows."""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np

REACTIVE_AGENTS = ("straight", "bee", "bee_robust", "vfh")
LEARNED_AGENTS = ("ppo_flow", "ppo_robust", "ppo_oracle")
AGENT_NAMES = REACTIVE_AGENTS + LEARNED_AGENTS


class Agent(Protocol):
    """What the evaluation needs of an agent: stable-baselines3's ``predict``."""

    def predict(
        self,
        observation: dict[str, np.ndarray],
        state: Any = None,
        episode_start: np.ndarray | None = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Any]: ...
