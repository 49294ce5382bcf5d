"""An agent written as a FlowNav user would write one, outside ``agents/``: steer sideways toward the image
column with the fewest near depths.

Score it on the suite's frozen test layouts (from the repository root)::

    flownav score --agent tests/examples/open_gap_agent.py:make_agent --layouts 30
    flownav leaderboard --include runs/score/score.csv

Anything with stable-baselines3's ``predict`` works the same way: a trained SB3 model, a torch module behind a
small wrapper, a hand-written rule like this one.
"""

from __future__ import annotations

import numpy as np

# The observation's histogram holds, per (sector row, sector column), the fraction of the sector's valid depth
# points in each depth bin; the first bins are the nearest depths (flownav_env.settings: depth_bin_edges).
NEAR_BINS = 2


class OpenGapAgent:
    """Lateral command toward the emptier side; no climb, no yaw."""

    def __init__(self, gain: float = 1.5) -> None:
        self.gain = gain

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        histogram = np.asarray(observation["depth_histogram"], np.float64)
        near = histogram[..., :NEAR_BINS].sum(axis=(-3, -1))  # per column, over rows and the near bins
        columns = near.shape[-1]
        side = np.linspace(-1.0, 1.0, columns)  # image columns, left (-1) to right (+1)
        total = near.sum(axis=-1, keepdims=True)
        # Push away from where the near points are: their weighted side, mirrored.
        push = -(near * side).sum(axis=-1) / np.maximum(total[..., 0], 1e-9)
        lateral = np.clip(self.gain * push, -1.0, 1.0)
        # (lateral, vertical, yaw rate); a positive lateral command moves right.
        action = np.stack([lateral, np.zeros_like(lateral), np.zeros_like(lateral)], axis=-1)
        return action.astype(np.float32), state


def make_agent() -> OpenGapAgent:
    """The factory ``flownav score --agent tests/examples/open_gap_agent.py:make_agent`` calls."""
    return OpenGapAgent()
