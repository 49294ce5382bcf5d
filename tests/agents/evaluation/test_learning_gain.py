"""The best ranked learned agent against the best ranked rule, per tier."""

from __future__ import annotations

import numpy as np

from agents.analysis.paired import rank_tier
from agents.evaluation.learning_gain import CAMERA_MARGIN, learning_gain, learning_gains


def _failures(rng: np.random.Generator) -> dict[str, np.ndarray]:
    layouts = 200
    return {
        "bee_ttc": (rng.random((1, layouts)) < 0.40).astype(float),
        "vfh": (rng.random((1, layouts)) < 0.60).astype(float),
        "ppo_flow": (rng.random((10, layouts)) < 0.10).astype(float),
        "ppo_oracle": np.zeros((5, layouts)),
    }


def test_the_learned_agent_that_fails_least_is_set_against_the_rule_that_fails_least():
    failures = _failures(np.random.default_rng(0))
    ranking = rank_tier(failures, privileged=["ppo_oracle"], learned=["ppo_flow", "ppo_oracle"])
    gain = learning_gain("hard", failures, ranking)
    assert gain is not None
    assert (gain.learned, gain.rule) == ("ppo_flow", "bee_ttc")
    assert gain.learned_failure == float(failures["ppo_flow"].mean())
    assert gain.comparison.difference == gain.learned_failure - gain.rule_failure
    assert gain.comparison.high < 0.0  # 0.10 against 0.40 on 200 layouts is told apart
    assert gain.comparison.fails_less == "ppo_flow"


def test_a_tier_with_no_ranked_learned_agent_has_no_gain():
    failures = _failures(np.random.default_rng(1))
    failures["ppo_flow"] = failures["ppo_flow"][:3]  # provisional: 3 seeds
    ranking = rank_tier(failures, privileged=["ppo_oracle"], learned=["ppo_flow", "ppo_oracle"])
    assert learning_gain("hard", failures, ranking) is None
    assert learning_gains({"hard": failures}, {"hard": ranking}) == []


def test_the_learned_agent_is_set_against_the_camera_limited_reference_where_it_flew():
    failures = _failures(np.random.default_rng(2))
    ranking = rank_tier(failures, privileged=["ppo_oracle"], learned=["ppo_flow", "ppo_oracle"])
    gain = learning_gain("hard", failures, ranking)
    assert gain is not None and gain.camera is None and gain.within_camera_margin is None
    failures["planner_camera"] = np.zeros((1, 200))
    ranking = rank_tier(
        failures, privileged=["ppo_oracle", "planner_camera"], learned=["ppo_flow", "ppo_oracle"]
    )
    gain = learning_gain("hard", failures, ranking)
    assert gain is not None and gain.camera is not None
    assert (gain.camera.agent, gain.camera.reference) == ("ppo_flow", "planner_camera")
    assert gain.camera.difference == gain.learned_failure
    # 0.10 more than a reference that never fails: the interval reaches past the margin
    assert gain.camera.high > CAMERA_MARGIN and gain.within_camera_margin is False
    failures["planner_camera"] = failures["ppo_flow"][:1].copy()
    gain = learning_gain("hard", failures, ranking)
    assert gain is not None and gain.within_camera_margin is True
