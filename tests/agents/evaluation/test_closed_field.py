"""Suite v2 has no side door: a rule that slides sideways and flies straight, as a participant would write it to
pass the task without avoiding anything, fails on every v2 tier (it beat every published agent on v1)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import flownav_env  # noqa: F401  (registers the ids)
from agents.common.seeds import SUITE_V2_CHECK_SEED_START
from flownav_env.tiers import TIERS_BY_VERSION

# Where v1's lane lay: past its 4 m field plus a capsule's radius, inside its 6 m bound.
LANE_Y_M = 5.0
LAYOUTS_PER_TIER = 3


class SlidingRule:
    """Estimates its own sideways position by integrating the observed lateral velocity (``state[1]``, left
    positive), slides left to :data:`LANE_Y_M` and then holds it, flying straight."""

    def __init__(self, frame_rate: float = 10.0) -> None:
        self.interval = 1.0 / frame_rate
        self.y = 0.0

    def predict(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        state = observation["state"]
        self.y += float(state[1]) * self.interval
        # The action's lateral command is right-positive: negative slides left.
        lateral = float(np.clip(-(LANE_Y_M - self.y), -1.0, 1.0))
        return np.array([lateral, 0.0, 0.0], np.float32)


def fly(env_id: str, seed: int) -> dict[str, object]:
    env = gym.make(env_id, camera_width=64, camera_height=48)
    rule = SlidingRule()
    try:
        observation, info = env.reset(seed=seed)
        widest = 0.0
        while True:
            observation, _, terminated, truncated, info = env.step(rule.predict(observation))
            widest = max(widest, abs(float(info["position"][1])))
            if terminated or truncated:
                return {"success": info["success"], "widest": widest, "progress": info["progress"]}
    finally:
        env.close()


@pytest.mark.parametrize("name", list(TIERS_BY_VERSION["2"]))
def test_a_sliding_rule_fails_on_every_v2_tier(name: str) -> None:
    env_id = TIERS_BY_VERSION["2"][name].env_id
    flights = [fly(env_id, SUITE_V2_CHECK_SEED_START + k) for k in range(LAYOUTS_PER_TIER)]
    assert min(flight["widest"] for flight in flights) > 1.0  # it did slide toward the old lane
    assert not any(flight["success"] for flight in flights), flights


def test_the_same_rule_passed_v1_through_its_lane() -> None:
    """The control: on v1's open field the rule reaches the goal beside the capsules (when it gets through the
    field on its way there)."""
    env_id = TIERS_BY_VERSION["1"]["clean"].env_id
    flights = [fly(env_id, SUITE_V2_CHECK_SEED_START + k) for k in range(LAYOUTS_PER_TIER)]
    assert any(flight["success"] and flight["widest"] > 4.5 for flight in flights), flights
