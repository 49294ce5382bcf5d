"""The privileged planner: registered as a shipped agent that asks for observe_layout and is declared
privileged, its planning maths on arrays, and real flights on validation layouts of the hard tier."""

from __future__ import annotations

import re

import gymnasium as gym
import numpy as np
import pytest

import flownav_env  # noqa: F401  (registers the env ids)
from agents.common.seeds import PLANNER_TUNING_SEED_START
from agents.evaluation.episode import run_episode
from agents.policies import AGENT_NAMES, PRIVILEGED_AGENTS, agent_env_kwargs, is_privileged, load_agent
from agents.policies.planner import (
    COLLISION_COST,
    PlannerAgent,
    build_cost_to_go,
    capsule_clearance,
    plan_grid,
    stage_cost,
)
from flownav_env.tiers import TIERS, check_agent_settings

SMALL = {"camera_width": 64, "camera_height": 48, "depth_error_info": False}
COST = {
    "drone_radius": 0.2,
    "lateral_bound": 6.0,
    "hard_margin": 0.08,
    "soft_clearance": 0.4,
    "clearance_weight": 2.0,
}


def test_the_planner_is_a_shipped_privileged_agent_asking_for_the_layout() -> None:
    assert "planner" in AGENT_NAMES and "planner" in PRIVILEGED_AGENTS and is_privileged("planner")
    assert agent_env_kwargs("planner") == {"observe_layout": True}
    assert isinstance(load_agent("planner"), PlannerAgent)
    check_agent_settings("planner", agent_env_kwargs("planner"), "hard", privileged=is_privileged("planner"))


def test_clearance_and_stage_cost_see_capsules_and_bounds() -> None:
    capsules = np.array([[5.0, 0.0, 0.5]])
    clearance = capsule_clearance(5.0, np.array([0.0, 1.0, 3.0]), capsules)
    np.testing.assert_allclose(clearance, [-0.5, 0.5, 2.5])
    assert capsule_clearance(9.0, np.array([0.0]), capsules)[0] == np.inf
    cost = stage_cost(clearance, np.array([0.0, 1.0, 3.0]), **COST)
    assert cost[0] == COLLISION_COST and 0.0 < cost[1] < COST["clearance_weight"] and cost[2] == 0.0
    assert stage_cost(np.array([np.inf]), np.array([5.9]), **COST)[0] == COLLISION_COST


def test_the_cost_to_go_is_free_in_the_open_and_steers_around_a_capsule() -> None:
    grid = plan_grid(6.0, 1.0, 0.1, 15, 9)
    capsules = np.array([[6.0, 0.0, 0.5]])
    table = build_cost_to_go(capsules, 10.0, 0.2, grid, COST, 0.01, 0.05)
    assert table.shape == (51, 9, len(grid.y), 15) and (table[-1] == 0.0).all()
    still, centre = 4, int(np.argmin(np.abs(grid.y)))
    level = int(np.argmin(np.abs(grid.vy)))
    # Far to the side nothing is in the way; straight at the capsule from 1 m it is too late to get by.
    assert table[0, still, int(np.argmin(np.abs(grid.y - 4.0))), level] == pytest.approx(0.0, abs=1e-6)
    assert table[25, still, centre, level] >= COLLISION_COST - 1e-3
    assert table[0, still, centre, level] < 1.0


def test_planner_parameters_and_observations_are_checked_in_one_line() -> None:
    with pytest.raises(ValueError, match=re.escape("hard_margin must be > 0, got 0.0")):
        PlannerAgent(hard_margin=0.0)
    with pytest.raises(
        ValueError, match=re.escape("commands must be an odd integer >= 3 (0 among them), got 4")
    ):
        PlannerAgent(commands=4)
    with pytest.raises(ValueError, match=re.escape("make the env with observe_layout=True")):
        PlannerAgent().predict({"state": np.zeros(7)}, episode_start=np.ones(1, bool))


def test_a_batch_or_another_frame_rate_is_refused() -> None:
    env = gym.make(TIERS["hard"].env_id, **TIERS["hard"].settings, observe_layout=True, **SMALL)
    try:
        observation, _ = env.reset(seed=PLANNER_TUNING_SEED_START)
    finally:
        env.close()
    batch = {key: np.stack([value, value]) for key, value in observation.items()}
    with pytest.raises(ValueError, match=re.escape("the planner flies one env at a time, got a batch of 2")):
        PlannerAgent().predict(batch, episode_start=np.ones(2, bool))
    course = observation["course"].copy()
    course[8] = 20.0
    with pytest.raises(ValueError, match=re.escape("fitted at frame_rate=10 Hz, got 20")):
        PlannerAgent().predict({**observation, "course": course}, episode_start=np.ones(1, bool))


def test_the_planner_flies_three_validation_layouts_of_the_hard_tier() -> None:
    # Measured: these three layouts succeed with at least 0.3 m between the drone's centre and a capsule.
    env = gym.make(TIERS["hard"].env_id, **TIERS["hard"].settings, **agent_env_kwargs("planner"), **SMALL)
    agent = load_agent("planner")
    try:
        records = [
            run_episode(env, agent, seed)
            for seed in range(PLANNER_TUNING_SEED_START, PLANNER_TUNING_SEED_START + 3)
        ]
    finally:
        env.close()
    assert all(record.success for record in records)
    assert min(record.min_clearance_m for record in records) > 0.3
