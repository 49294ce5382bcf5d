"""Histogram resolutions a rule may ask a tier for: the env settings and the rule's bins that go with them."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import flownav_env  # noqa: F401  (registers the ids)
from agents.policies import load_agent
from agents.policies.histogram_resolution import FINE_BIN_EDGES, HistogramResolution
from estimator import DEFAULT_BIN_EDGES
from flownav_env.tiers import check_agent_settings


def test_the_default_resolution_asks_the_env_for_nothing() -> None:
    default = HistogramResolution()
    assert default.name == "3x5" and default.env_kwargs() == {} and default.rule_parameters() == {}
    assert default.bin_edges == tuple(DEFAULT_BIN_EDGES)


def test_a_finer_resolution_asks_for_what_differs_and_any_tier_allows_it() -> None:
    columns = HistogramResolution((3, 15))
    assert columns.name == "3x15" and columns.env_kwargs() == {"histogram_sectors": (3, 15)}
    assert columns.rule_parameters() == {}
    fine = HistogramResolution((3, 15), FINE_BIN_EDGES)
    assert fine.name == "3x15-9bins" and fine.rule_parameters() == {"bin_edges": FINE_BIN_EDGES}
    check_agent_settings("bee_ttc", fine.env_kwargs(), "hard_noisy")  # an observation setting: no error


def test_a_rule_flies_a_real_step_at_the_resolution_it_asks_for() -> None:
    fine = HistogramResolution((3, 15), FINE_BIN_EDGES)
    env = gym.make(
        "FlowNavHard-v1", camera_width=96, camera_height=72, observe_unresolved=True, **fine.env_kwargs()
    )
    observation, _ = env.reset(seed=0)
    observation, *_ = env.step(np.zeros(3))
    env.close()
    assert observation["depth_histogram"].shape == (3, 15, 9)
    action, _ = load_agent("bee_ttc", **fine.rule_parameters()).predict(observation)
    assert action.shape == (3,) and np.all(np.abs(action) <= 1)


@pytest.mark.parametrize(
    ("sectors", "edges", "message"),
    [
        ((3, 0), DEFAULT_BIN_EDGES, r"histogram_sectors\[1\] must be an integer in \[1, 32\], got 0"),
        ((3, 40), DEFAULT_BIN_EDGES, r"histogram_sectors\[1\] must be an integer in \[1, 32\], got 40"),
        (
            (3, 5),
            (2.0, 1.0),
            r"depth_bin_edges must be >= 2 increasing finite depths >= 0 m, got \(2.0, 1.0\)",
        ),
    ],
)
def test_a_resolution_the_env_would_refuse_is_refused_naming_the_value_and_range(
    sectors, edges, message
) -> None:
    with pytest.raises(ValueError, match=message):
        HistogramResolution(sectors, tuple(edges))
