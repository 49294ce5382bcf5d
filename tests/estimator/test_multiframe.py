"""Tests of estimator.multiframe and FlowDepthEstimator(baseline_frames=...): exact synthetic geometry, the
track window's bookkeeping, real ICL-NUIM frames, and bad input."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from helpers import TESTDATA

from estimator import CameraIntrinsics, FlowDepthEstimator
from estimator.accuracy import read_trajectory_log, relative_motion
from estimator.geometry import euler_zyx_to_rotation, project_points
from estimator.multiframe import (
    TrackWindow,
    compose,
    motions_to_latest,
    nearest_within,
    range_over_baselines,
)

ICL = TESTDATA / "icl_nuim_livingroom1"
ICL_INTRINSICS = CameraIntrinsics(fx=525.0, fy=525.0, cx=319.5, cy=239.5, width=640, height=480)
FOCAL = np.array([600.0, 600.0])


def _range(anchors, previous, following, baseline, to_previous, step):
    """range_over_baselines with this file's camera and the estimator's default thresholds (1 px, 1 px)."""
    return range_over_baselines(
        anchors, previous, following, baseline, to_previous, step, FOCAL, "triangulation", 1.0, 1.0
    )


def _step(roll: float, pitch: float, yaw: float, translation: tuple[float, float, float]):
    return euler_zyx_to_rotation(roll, pitch, yaw), np.array(translation, np.float64)


def test_compose_applies_the_first_motion_then_the_second() -> None:
    first = _step(0.01, -0.02, 0.03, (0.1, 0.0, -0.2))
    then = _step(-0.03, 0.01, 0.02, (0.0, 0.05, -0.1))
    point = np.array([0.3, -0.2, 4.0])
    rotation, translation = compose(first, then)
    expected = then[0] @ (first[0] @ point + first[1]) + then[1]
    np.testing.assert_allclose(rotation @ point + translation, expected, atol=1e-12)


def test_motions_to_latest_chain_the_steps_newest_first() -> None:
    older = _step(0.0, 0.02, 0.0, (0.0, 0.0, -0.1))
    newer = _step(0.01, 0.0, -0.01, (0.02, 0.0, -0.1))
    identity, one_back, two_back = motions_to_latest([newer, older], 3)
    np.testing.assert_array_equal(identity[0], np.eye(3))
    np.testing.assert_array_equal(identity[1], np.zeros(3))
    np.testing.assert_allclose(one_back[0], newer[0])
    point = np.array([1.0, 0.5, 6.0])
    expected = newer[0] @ (older[0] @ point + older[1]) + newer[1]
    np.testing.assert_allclose(two_back[0] @ point + two_back[1], expected, atol=1e-12)
    assert len(motions_to_latest([newer, older], 2)) == 2


def test_ranging_over_several_baselines_recovers_the_depth_in_the_previous_camera() -> None:
    rng = np.random.default_rng(3)
    count = 60
    points_oldest = np.column_stack(
        [rng.uniform(-2, 2, count), rng.uniform(-1, 1, count), rng.uniform(3, 8, count)]
    )
    # Five frames, each step mapping one to the following; the last is the next frame.
    steps = [_step(0.01 * k, -0.01, 0.02, (0.02, -0.01, -0.1)) for k in range(4)]
    frames = [points_oldest]
    for rotation, translation in steps:
        frames.append(frames[-1] @ rotation.T + translation)
    _, three_back, two_back, previous, following = frames
    baseline = np.repeat([3, 2, 1], count // 3)  # frames from each point's anchor to the next frame
    anchors = np.concatenate([three_back[:20], two_back[20:40], previous[40:]])
    anchor_normalized = project_points(anchors)
    next_normalized = project_points(following)
    # Stored steps newest first: the one into the previous frame, then the one before.
    to_previous = motions_to_latest([steps[2], steps[1]], 3)
    ranging = _range(
        anchor_normalized, project_points(previous), next_normalized, baseline, to_previous, steps[3]
    )
    np.testing.assert_allclose(ranging.depth, previous[:, 2], rtol=1e-9)
    # Exact tracks fail only the parallax check, near the focus of expansion.
    np.testing.assert_array_equal(ranging.ok, ranging.parallax_px >= 1.0)
    assert ranging.ok.mean() > 0.8
    assert not ranging.off_epipolar.any()
    # A longer baseline gives the same point more parallax.
    single = _range(
        project_points(previous),
        project_points(previous),
        next_normalized,
        np.ones(count, int),
        to_previous,
        steps[3],
    )
    assert np.median(ranging.parallax_px[:20] / single.parallax_px[:20]) > 2.5
    np.testing.assert_array_equal(ranging.baseline[ranging.ok], baseline[ranging.ok])
    # A drifted anchor (2 px across its epipolar line) falls back to the last frame pair and is flagged.
    drifted_anchors = anchor_normalized.copy()
    drifted_anchors[:20] += [0.0, 2.0 / FOCAL[1]]
    fallback = _range(
        drifted_anchors, project_points(previous), next_normalized, baseline, to_previous, steps[3]
    )
    redone = fallback.drifted[:20] & fallback.ok[:20]
    assert redone.sum() >= 10
    np.testing.assert_array_equal(fallback.baseline[:20][redone], 1)
    np.testing.assert_allclose(fallback.depth[:20][redone], previous[:20, 2][redone], rtol=1e-9)
    assert not fallback.off_epipolar.any()


def test_a_point_pushed_off_its_epipolar_line_is_flagged() -> None:
    step = _step(0.0, 0.0, 0.0, (0.0, 0.0, -0.1))
    previous = np.array([[1.0, 0.5, 5.0], [-1.0, 0.2, 4.0]])
    following = previous + step[1]
    next_normalized = project_points(following)
    next_normalized[1] += [0.0, 0.05]  # 15 px off the radial line from the focus of expansion
    ranging = _range(
        project_points(previous),
        project_points(previous),
        next_normalized,
        np.ones(2, int),
        motions_to_latest([], 1),
        step,
    )
    np.testing.assert_array_equal(ranging.off_epipolar, [False, True])
    np.testing.assert_array_equal(ranging.ok, [True, False])


def test_track_window_keeps_the_oldest_view_within_the_window() -> None:
    window = TrackWindow(3)
    window.adopt(np.array([[10.0, 10.0], [20.0, 20.0]], np.float32))
    step = (np.eye(3), np.zeros(3))
    window.advance(np.array([[11.2, 10.0], [21.0, 20.0]], np.float32), np.array([True, False]), step)
    # The corner at (11, 10) is the first track found again, which goes on from its own position (11.2, 10);
    # (30, 30) is new; the track no corner found is gone.
    window.adopt(np.array([[11.0, 10.0], [30.0, 30.0]], np.float32))
    np.testing.assert_array_equal(window.latest_points, np.array([[11.2, 10.0], [30.0, 30.0]], np.float32))
    positions, back = window.anchors()
    np.testing.assert_array_equal(back, [1, 0])
    np.testing.assert_array_equal(positions, [[10.0, 10.0], [30.0, 30.0]])
    for _ in range(2):
        moved = window.latest_points + np.array([1.0, 0.0], np.float32)
        window.advance(moved, np.array([True, True]), step)
        window.adopt(window.latest_points.copy())
    positions, back = window.anchors()
    # The first track is 4 frames old, but the window holds 3: its anchor is 2 frames back.
    np.testing.assert_array_equal(back, [2, 2])
    np.testing.assert_array_equal(positions, np.array([[11.2, 10.0], [30.0, 30.0]], np.float32))
    assert len(window.steps) == 2
    window.advance(window.latest_points, np.array([True, True]), step, restart=np.array([True, False]))
    window.adopt(window.latest_points.copy())
    positions, back = window.anchors()
    np.testing.assert_array_equal(back, [1, 2])  # the restarted track keeps only its last two views
    np.testing.assert_array_equal(positions[0], np.array([13.2, 10.0], np.float32))
    window.reset()
    assert len(window.latest_points) == 0 and window.steps == []


def test_nearest_within_finds_the_closest_candidate_inside_the_radius() -> None:
    candidates = np.array([[10.4, 10.0], [11.0, 10.0], [50.0, 50.0], [np.nan, np.nan]], np.float32)
    points = np.array([[11.0, 10.0], [10.0, 10.0], [52.0, 50.0], [80.0, 5.0]], np.float32)
    np.testing.assert_array_equal(nearest_within(points, candidates, 1.5), [1, 0, -1, -1])
    np.testing.assert_array_equal(nearest_within(points, candidates, 2.0), [1, 0, 2, -1])
    assert len(nearest_within(np.empty((0, 2)), candidates, 1.5)) == 0
    np.testing.assert_array_equal(nearest_within(points, np.empty((0, 2)), 1.5), [-1] * 4)


@pytest.fixture(scope="module")
def icl_stream():
    if not ICL.is_dir():
        pytest.skip(f"third-party test data not found at {ICL}")
    frames = [cv2.imread(str(ICL / "color" / f"{index:05d}.jpg"), cv2.IMREAD_GRAYSCALE) for index in range(5)]
    depth = cv2.imread(str(ICL / "depth" / "00003.png"), cv2.IMREAD_UNCHANGED).astype(np.float64) / 1000.0
    return frames, depth, read_trajectory_log(ICL / "trajectory.log")


def _stream(frames, poses, baseline_frames):
    estimator = FlowDepthEstimator(ICL_INTRINSICS, baseline_frames=baseline_frames)
    result = estimator.update(frames[0], np.eye(3), np.zeros(3))
    for index in range(1, len(frames)):
        result = estimator.update(frames[index], *relative_motion(poses[index - 1], poses[index]))
    return result


def test_multi_frame_depths_on_icl_nuim_are_more_accurate_on_the_same_corners(icl_stream) -> None:
    frames, depth_3, poses = icl_stream
    results = {frames_: _stream(frames, poses, frames_) for frames_ in (1, 4)}
    errors = {}
    for frames_, result in results.items():
        pixel = np.rint(result.points[result.valid]).astype(np.intp)
        truth = depth_3[pixel[:, 1], pixel[:, 0]]
        errors[frames_] = np.abs(result.depth[result.valid] - truth)[truth > 0] / truth[truth > 0]
    single, multi = results[1], results[4]
    assert single.baseline_frames is None
    assert multi.baseline_frames.max() == 4 and multi.baseline_frames.min() == 1
    # One point per FAST corner, as with two frames (a continued track at its own sub-pixel position).
    assert multi.num_points == single.num_points
    assert np.max(np.abs(np.sort(multi.points[:, 0]) - np.sort(single.points[:, 0]))) <= 1.5
    assert multi.num_valid >= single.num_valid
    assert np.median(errors[4]) < 0.9 * np.median(errors[1])
    assert np.mean(errors[4] < 0.1) > 0.9


def test_one_frame_baseline_is_the_two_frame_estimator(icl_stream) -> None:
    frames, _, poses = icl_stream
    default = _stream(frames[:3], poses, 1)
    pair = FlowDepthEstimator(ICL_INTRINSICS).estimate(
        frames[1], frames[2], *relative_motion(poses[1], poses[2])
    )
    np.testing.assert_array_equal(default.depth, pair.depth)
    np.testing.assert_array_equal(default.valid, pair.valid)


def test_reset_forgets_the_tracks(icl_stream) -> None:
    frames, _, poses = icl_stream
    estimator = FlowDepthEstimator(ICL_INTRINSICS, baseline_frames=3)
    for index in range(3):
        motion = (np.eye(3), np.zeros(3)) if index == 0 else relative_motion(poses[index - 1], poses[index])
        estimator.update(frames[index], *motion)
    estimator.reset()
    assert estimator.update(frames[3], np.eye(3), np.zeros(3)).num_points == 0
    result = estimator.update(frames[4], *relative_motion(poses[3], poses[4]))
    assert result.baseline_frames.max() == 1


@pytest.mark.parametrize("value", [0, 17, 2.5, True, "4"])
def test_baseline_frames_out_of_range_is_rejected(value) -> None:
    with pytest.raises(
        ValueError, match=r"baseline_frames must be an integer with 1 <= baseline_frames <= 16"
    ):
        FlowDepthEstimator(ICL_INTRINSICS, baseline_frames=value)
