"""The observation-limited reference integrated over frames: candidates spread over a capsule's first cell, each
later frame keeping those its cell allows, the plan on their mean; on hand-made views and on the real env."""

from __future__ import annotations

import re

import numpy as np
import pytest
from helpers import fly_hard_camera_layout

from agents.policies import agent_env_kwargs, is_privileged
from agents.policies.camera_view import front_points, histogram_cells
from agents.policies.planner_camera import ObservedCameraPlannerAgent
from agents.policies.planner_camera_filtered import FilteredCameraPlannerAgent
from agents.policies.registry import planner_class
from estimator.camera import CameraIntrinsics

# A camera looking along world +x: OpenCV x (right) is world -y, y (down) is world -z; the env's 160 x 120 px.
LOOKING_ALONG_X = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
INTRINSICS = CameraIntrinsics.from_fov(160, 120, 60.0)

EDGES = np.array([0.0, 1.0, 2.0, 3.0, 5.0, 8.0, 13.0])
COLUMNS = 5
CAPSULE = np.array([[2.6, 0.35, 0.5]])


def _camera(x: float, y: float = 0.0) -> np.ndarray:
    """The env's ``camera`` key for a camera at (x, y, 1) looking along +x."""
    return np.concatenate(
        [[x, y, 1.0], LOOKING_ALONG_X.reshape(-1), [INTRINSICS.fx, INTRINSICS.cx, INTRINSICS.width]]
    )


def _cell(capsules: np.ndarray, camera: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    view = (camera[:3], camera[3:12].reshape(3, 3), camera[12], camera[13], int(camera[14]), COLUMNS, EDGES)
    return histogram_cells(front_points(capsules, camera[:3]), *view)


def test_it_is_declared_a_privileged_planner_at_two_resolutions() -> None:
    for name in ("planner_camera_filtered", "planner_camera_filtered_3x15"):
        assert planner_class(name) is FilteredCameraPlannerAgent and is_privileged(name)
    assert agent_env_kwargs("planner_camera_filtered_3x15")["histogram_sectors"] == (3, 15)


@pytest.mark.parametrize("grid", [1, 65, 2.5, True])
def test_a_bad_grid_is_a_one_line_error(grid: object) -> None:
    with pytest.raises(ValueError, match=re.escape(f"grid must be an integer in [2, 64], got {grid!r}")):
        FilteredCameraPlannerAgent(grid=grid)  # type: ignore[arg-type]


def test_the_first_sighting_spreads_candidates_over_the_cell_and_later_frames_narrow_them() -> None:
    agent = FilteredCameraPlannerAgent(grid=11)
    rows = np.array([4])
    first = _camera(0.0)
    estimate, inside = agent._estimates(rows, CAPSULE, first, EDGES, COLUMNS)
    spread = agent._candidates[4]
    assert inside.all() and len(spread) == 121
    # Every candidate, and the estimate, lies where the histogram saw the capsule.
    cell = tuple(axis[0] for axis in _cell(CAPSULE, first)[:2])
    circles = np.column_stack([spread, np.full(len(spread), 0.5)])
    sectors, bins, _ = _cell(circles, first)
    assert set(zip(sectors.tolist(), bins.tolist(), strict=True)) == {cell}
    observed, _ = ObservedCameraPlannerAgent()._estimates(rows, CAPSULE, first, EDGES, COLUMNS)
    np.testing.assert_allclose(estimate[0, 2], 0.5)
    # Closer, from one side: the new cell keeps a subset, whose mean is nearer the capsule than one frame's guess.
    for x, y in ((0.6, -0.3), (1.0, 0.2), (1.3, -0.1)):
        estimate, _ = agent._estimates(rows, CAPSULE, _camera(x, y), EDGES, COLUMNS)
    kept = agent._candidates[4]
    assert 0 < len(kept) < len(spread) and all(any(np.allclose(k, s) for s in spread) for k in kept)
    error = np.hypot(*(estimate[0, :2] - CAPSULE[0, :2]))
    assert error < np.hypot(*(observed[0, :2] - CAPSULE[0, :2]))


def test_a_frame_no_candidate_agrees_with_starts_again_from_its_cell() -> None:
    agent = FilteredCameraPlannerAgent(grid=5)
    rows = np.array([0])
    agent._estimates(rows, CAPSULE, _camera(0.0), EDGES, COLUMNS)
    moved = CAPSULE + np.array([[3.0, 0.0, 0.0]])  # the same row now somewhere no candidate allows
    estimate, _ = agent._estimates(rows, moved, _camera(0.0), EDGES, COLUMNS)
    circles = np.column_stack([agent._candidates[0], np.full(25, 0.5)])
    assert set(zip(*(axis.tolist() for axis in _cell(circles, _camera(0.0))[:2]), strict=True)) == {
        tuple(axis[0] for axis in _cell(moved, _camera(0.0))[:2])
    }
    # Started again from the new cell alone: near where one frame's histogram puts the capsule.
    observed, _ = ObservedCameraPlannerAgent()._estimates(rows, moved, _camera(0.0), EDGES, COLUMNS)
    assert np.hypot(*(estimate[0, :2] - observed[0, :2])) < 0.3


def test_it_flies_the_hard_tier_and_forgets_between_episodes() -> None:
    agent = FilteredCameraPlannerAgent()
    flown = fly_hard_camera_layout(agent, 15)
    assert agent.known_capsules and set(agent._candidates) >= set(agent.known_capsules)
    assert all(action.shape == (3,) and np.all(np.abs(action) <= 1.0) for _, action in flown)
    agent.predict(flown[0][0], episode_start=np.ones(1, bool))
    assert set(agent._candidates) <= set(agent.known_capsules)
