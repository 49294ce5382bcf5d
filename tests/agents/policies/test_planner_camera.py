"""The camera-limited planners: shipped privileged agents asking for observe_layout, their parameters checked in
one line, and short real flights in which they know only capsules the camera has seen."""

from __future__ import annotations

import re

import numpy as np
import pytest
from helpers import fly_hard_camera_layout

import flownav_env  # noqa: F401  (registers the env ids)
from agents.policies import AGENT_NAMES, PRIVILEGED_AGENTS, agent_env_kwargs, is_privileged, load_agent
from agents.policies.base import PLANNERS
from agents.policies.planner import build_cost_to_go
from agents.policies.planner_camera import CameraPlannerAgent, ObservedCameraPlannerAgent
from agents.policies.teachers import PlannerTeacher, check_teacher_params, make_teacher
from flownav_env.tiers import TIERS, check_agent_settings

# The hard tier: a closed field (capsules across the whole lateral bound), so capsules come into view early.
HARD = TIERS["hard"]


@pytest.mark.parametrize(
    ("name", "kind"),
    [("planner_camera", CameraPlannerAgent), ("planner_camera_observed", ObservedCameraPlannerAgent)],
)
def test_each_is_a_shipped_privileged_planner_asking_for_the_layout(name: str, kind: type) -> None:
    assert name in AGENT_NAMES and name in PLANNERS and name in PRIVILEGED_AGENTS and is_privileged(name)
    assert agent_env_kwargs(name) == {"observe_layout": True}
    agent = load_agent(name, view_range=1.5, memory=False)
    assert type(agent) is kind and agent.view_range == 1.5 and agent.memory is False
    check_agent_settings(name, agent_env_kwargs(name), "hard", privileged=is_privileged(name))


@pytest.mark.parametrize(
    ("parameters", "message"),
    [
        ({"view_range": 0.0}, "view_range must be a finite distance > 0 (m), got 0.0"),
        ({"view_range": -1.0}, "view_range must be a finite distance > 0 (m), got -1.0"),
        ({"view_range": float("inf")}, "view_range must be a finite distance > 0 (m), got inf"),
        ({"view_range": True}, "view_range must be a finite distance > 0 (m), got True"),
        ({"memory": 1}, "memory must be True or False, got 1"),
        ({"hard_margin": 0.0}, "hard_margin must be > 0, got 0.0"),
    ],
)
def test_bad_parameters_are_one_line_errors(parameters: dict, message: str) -> None:
    for kind in (CameraPlannerAgent, ObservedCameraPlannerAgent):
        with pytest.raises(ValueError, match=re.escape(message)):
            kind(**parameters)


def test_an_env_without_the_privileged_keys_is_refused_in_one_line() -> None:
    with pytest.raises(
        ValueError,
        match=re.escape("planner_camera reads layout, layout_mask, true_state, course, camera, depth_"),
    ):
        CameraPlannerAgent().predict({"state": np.zeros(7)}, episode_start=np.ones(1, bool))
    with pytest.raises(ValueError, match=re.escape("planner_camera_observed reads layout, layout_mask")):
        ObservedCameraPlannerAgent().predict({"state": np.zeros(7)}, episode_start=np.ones(1, bool))


def _in_reach(observation: dict[str, np.ndarray], view_range: float) -> set[int]:
    """The capsules whose surface lies within ``view_range`` of the camera."""
    capsules = observation["layout"][observation["layout_mask"] > 0.5]
    camera = observation["camera"][:2]
    surface = np.hypot(*(capsules[:, :2] - camera).T) - capsules[:, 2]
    return set(np.flatnonzero(surface <= view_range).tolist())


def test_it_knows_only_capsules_it_has_seen_and_replans_as_they_come() -> None:
    agent = CameraPlannerAgent()
    flown = fly_hard_camera_layout(agent, 20)
    reached = set().union(*(_in_reach(observation, agent.view_range) for observation, _ in flown))
    assert agent.known_capsules and set(agent.known_capsules) <= reached
    layout = flown[-1][0]["layout"]
    for row, capsule in agent.known_capsules.items():
        np.testing.assert_array_equal(capsule, layout[row])
    assert agent.replans >= 1
    assert all(action.shape == (3,) and np.all(np.abs(action) <= 1.0) for _, action in flown)
    # Far fewer than the whole field: the map would hold every capsule.
    assert len(agent.known_capsules) < int(flown[-1][0]["layout_mask"].sum())


def test_without_memory_it_knows_only_what_is_in_view_now() -> None:
    agent = CameraPlannerAgent(memory=False)
    flown = fly_hard_camera_layout(agent, 20)
    assert set(agent.known_capsules) <= _in_reach(flown[-1][0], agent.view_range)


def test_the_observed_planner_knows_capsules_where_the_histogram_puts_them() -> None:
    agent = ObservedCameraPlannerAgent()
    flown = fly_hard_camera_layout(agent, 20)
    layout = flown[-1][0]["layout"]
    whole = [row for row, seen_whole in agent.seen_whole.items() if seen_whole]
    assert whole and set(agent.seen_whole) == set(agent.known_capsules)
    for row in whole:
        # Seen whole, off by at most half a 1 m depth bin and half a 15° sector column at 2.5 m, and the turn
        # that moves its centre behind the front point.
        capsule = agent.known_capsules[row]
        assert capsule[2] == layout[row, 2]
        assert 0.0 < np.hypot(*(capsule[:2] - layout[row, :2])) < 0.5 + 2.5 * np.tan(np.radians(7.6)) + 0.1


def test_a_camera_planner_teaches_over_a_batch_with_its_own_parameters() -> None:
    teacher = make_teacher("planner_camera", {"view_range": 1.5, "memory": False})
    assert isinstance(teacher, PlannerTeacher) and teacher.planner_class is CameraPlannerAgent
    with pytest.raises(
        ValueError, match=re.escape("key 'imitation.teacher_params.memory' must be true or false")
    ):
        check_teacher_params("planner_camera", {"memory": 1}, "config.yaml")
    with pytest.raises(ValueError, match=re.escape("view_range must be a finite distance > 0 (m), got -1.0")):
        check_teacher_params("planner_camera_observed", {"view_range": -1.0}, "config.yaml")


@pytest.mark.parametrize("kind", [CameraPlannerAgent, ObservedCameraPlannerAgent])
def test_the_refilled_table_equals_one_built_afresh_for_what_it_knows(kind: type[CameraPlannerAgent]) -> None:
    agent = kind(memory=False)
    flown = fly_hard_camera_layout(agent, 30)
    assert agent.replans >= 2  # refilled over some stages more than once
    true, course = flown[-1][0]["true_state"], flown[-1][0]["course"]
    known = np.array([agent.known_capsules[row] for row in sorted(agent.known_capsules)]).reshape(-1, 3)
    fresh = build_cost_to_go(
        known,
        float(course[0]),
        agent._sweep.stage_dx,
        agent._sweep.grid,
        agent._cost_terms(course),
        agent.control_weight,
        agent.change_weight,
    )
    # From the drone's stage on (those behind it are never read again).
    here = agent._sweep.stage_of(float(true[0]))
    np.testing.assert_array_equal(agent._table[here:], fresh[here:])
