"""Tests of estimator.estimator: FlowDepthEstimator on real ICL-NUIM frames, streaming, parameters, inputs."""

from __future__ import annotations

import warnings

import cv2
import numpy as np
import pytest
from helpers import TESTDATA

from estimator import CameraIntrinsics, DepthPoints, FlowDepthEstimator
from estimator.accuracy import read_trajectory_log, relative_motion

ICL = TESTDATA / "icl_nuim_livingroom1"
ICL_INTRINSICS = CameraIntrinsics(fx=525.0, fy=525.0, cx=319.5, cy=239.5, width=640, height=480)
SMALL = CameraIntrinsics.from_fov(64, 48, 60.0)


@pytest.fixture(scope="module")
def icl():
    """ICL-NUIM frames 0-4 (RGB), ground-truth depth of frame 0 in metres, camera-to-world poses."""
    if not ICL.is_dir():
        pytest.skip(f"third-party test data not found at {ICL}")
    frames = [
        cv2.cvtColor(cv2.imread(str(ICL / "color" / f"{index:05d}.jpg")), cv2.COLOR_BGR2RGB)
        for index in range(5)
    ]
    depth = cv2.imread(str(ICL / "depth" / "00000.png"), cv2.IMREAD_UNCHANGED).astype(np.float64) / 1000.0
    return frames, depth, read_trajectory_log(ICL / "trajectory.log")


def _relative_errors(result: DepthPoints, true_depth: np.ndarray) -> np.ndarray:
    pixel = np.rint(result.points).astype(np.intp)
    truth = true_depth[pixel[:, 1], pixel[:, 0]]
    evaluated = result.valid & (truth > 0)
    return np.abs(result.depth[evaluated] - truth[evaluated]) / truth[evaluated]


@pytest.mark.parametrize("method", ["triangulation", "thesis"])
@pytest.mark.parametrize("last", [2, 4])
def test_icl_nuim_depth_against_ground_truth(icl, last, method):
    frames, true_depth, poses = icl
    rotation, translation = relative_motion(poses[0], poses[last])
    result = FlowDepthEstimator(ICL_INTRINSICS, method=method).estimate(
        frames[0], frames[last], rotation, translation
    )
    errors = _relative_errors(result, true_depth)
    assert result.num_valid >= 50
    assert len(errors) >= 50
    assert np.median(errors) <= 0.03
    assert np.all(np.isfinite(result.depth[result.valid])) and np.all(result.depth[result.valid] > 0)


def test_result_layout_and_timings(icl):
    frames, _, poses = icl
    rotation, translation = relative_motion(poses[0], poses[1])
    result = FlowDepthEstimator(ICL_INTRINSICS, max_points=300).estimate(
        frames[0], frames[1], rotation, translation
    )
    count = result.num_points
    assert 0 < count <= 300
    assert result.points.shape == result.next_points.shape == (count, 2)
    assert result.points.dtype == np.float32
    assert (
        result.depth.shape
        == result.valid.shape
        == result.tracked.shape
        == result.parallax_px.shape
        == (count,)
    )
    assert result.valid.dtype == bool
    assert not np.any(result.valid & ~result.tracked)
    assert result.num_tracked == int(result.tracked.sum()) and result.num_valid == int(result.valid.sum())
    assert {"fast", "flow", "depth", "total"} <= result.timings.keys()
    assert result.timings["total"] >= result.timings["flow"] > 0.0


def test_streaming_update_equals_estimate(icl):
    frames, _, poses = icl
    streaming = FlowDepthEstimator(ICL_INTRINSICS)
    pairwise = FlowDepthEstimator(ICL_INTRINSICS)
    first = streaming.update(frames[0], np.eye(3), np.zeros(3))
    assert first.num_points == 0 and first.points.shape == (0, 2)
    for index in (1, 2):
        rotation, translation = relative_motion(poses[index - 1], poses[index])
        streamed = streaming.update(frames[index], rotation, translation)
        reference = pairwise.estimate(frames[index - 1], frames[index], rotation, translation)
        assert streamed.num_valid > 50
        for name in ("points", "next_points", "depth", "valid", "tracked", "parallax_px"):
            np.testing.assert_array_equal(getattr(streamed, name), getattr(reference, name), err_msg=name)


def test_reset_starts_a_new_stream(icl):
    frames, _, poses = icl
    estimator = FlowDepthEstimator(ICL_INTRINSICS)
    estimator.update(frames[0], np.eye(3), np.zeros(3))
    rotation, translation = relative_motion(poses[0], poses[1])
    assert estimator.update(frames[1], rotation, translation).num_points > 0
    estimator.reset()
    assert estimator.update(frames[2], rotation, translation).num_points == 0


def test_gray_and_rgb_inputs_agree(icl):
    frames, _, poses = icl
    rotation, translation = relative_motion(poses[0], poses[2])
    gray = [cv2.cvtColor(frame, cv2.COLOR_RGB2GRAY) for frame in frames[:3]]
    estimator = FlowDepthEstimator(ICL_INTRINSICS)
    from_rgb = estimator.estimate(frames[0], frames[2], rotation, translation)
    from_gray = estimator.estimate(gray[0], gray[2], rotation, translation)
    np.testing.assert_array_equal(from_rgb.depth, from_gray.depth)


@pytest.mark.parametrize("method", ["triangulation", "thesis"])
def test_hovering_gives_no_valid_depth_and_no_warnings(icl, method):
    frames, _, poses = icl
    rotation, _ = relative_motion(poses[0], poses[1])
    estimator = FlowDepthEstimator(ICL_INTRINSICS, method=method)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        still = estimator.estimate(frames[0], frames[0], np.eye(3), np.zeros(3))
        rotating_only = estimator.estimate(frames[0], frames[1], rotation, np.zeros(3))
    assert still.num_tracked > 100 and still.num_valid == 0
    assert rotating_only.num_valid == 0


def test_per_frame_brightness_normalisation_survives_an_exposure_change(icl):
    frames, true_depth, poses = icl
    rotation, translation = relative_motion(poses[0], poses[2])
    darker = cv2.convertScaleAbs(frames[2], alpha=0.7)
    normalised = FlowDepthEstimator(ICL_INTRINSICS, normalize_brightness="frame").estimate(
        frames[0], darker, rotation, translation
    )
    raw = FlowDepthEstimator(ICL_INTRINSICS, normalize_brightness=False).estimate(
        frames[0], darker, rotation, translation
    )
    assert normalised.num_valid >= 200 and np.median(_relative_errors(normalised, true_depth)) <= 0.03
    assert raw.num_valid < 20


def test_pair_normalisation_restores_a_dark_scene(icl):
    """A scene lit at 25 %: on raw frames FAST's threshold finds few corners; the pair mode's shared contrast
    stretch gives them back, with both frames still mapped alike (as the brightness is constant)."""
    frames, true_depth, poses = icl
    rotation, translation = relative_motion(poses[0], poses[2])
    dark = [cv2.convertScaleAbs(frame, alpha=0.25) for frame in frames]
    paired = FlowDepthEstimator(ICL_INTRINSICS, normalize_brightness="pair").estimate(
        dark[0], dark[2], rotation, translation
    )
    raw = FlowDepthEstimator(ICL_INTRINSICS, normalize_brightness="off").estimate(
        dark[0], dark[2], rotation, translation
    )
    assert paired.num_valid >= 100 and paired.num_valid >= 3 * max(raw.num_valid, 1)
    assert np.median(_relative_errors(paired, true_depth)) <= 0.03


def test_true_and_false_select_pair_and_off_modes():
    assert FlowDepthEstimator(SMALL, normalize_brightness=True).normalize_brightness == "pair"
    assert FlowDepthEstimator(SMALL, normalize_brightness=False).normalize_brightness == "off"


def test_frame_without_corners_gives_empty_result():
    blank = np.full((48, 64), 90, np.uint8)
    result = FlowDepthEstimator(SMALL).estimate(blank, blank, np.eye(3), [0.1, 0.0, 0.0])
    assert result.num_points == 0 and result.depth.shape == (0,)
    assert result.timings["total"] > 0.0


def test_empty_depth_points():
    empty = DepthPoints.empty()
    assert (empty.num_points, empty.num_tracked, empty.num_valid) == (0, 0, 0)
    assert empty.points.shape == (0, 2) and empty.valid.dtype == bool
    assert {"fast", "flow", "depth", "total"} <= empty.timings.keys()


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"method": "sfm"}, r"method must be one of \('triangulation', 'thesis'\), got 'sfm'"),
        ({"fast_threshold": 0}, r"fast_threshold must be an integer with 1 <= fast_threshold <= 255, got 0"),
        ({"fast_threshold": 20.5}, r"fast_threshold must be an integer"),
        ({"max_points": 0}, r"max_points must be an integer with 1 <= max_points, got 0"),
        ({"win_size": 2}, r"win_size must be an integer with 3 <= win_size <= 101, got 2"),
        ({"max_level": 9}, r"max_level must be an integer with 0 <= max_level <= 8, got 9"),
        ({"fb_max_level": -1}, r"fb_max_level must be an integer with 0 <= fb_max_level <= 8, got -1"),
        ({"max_lk_error": 0.0}, r"max_lk_error must be a positive finite number"),
        ({"max_lk_error": float("nan")}, r"max_lk_error must be a positive finite number"),
        ({"spread_keypoints": 1}, r"spread_keypoints must be True or False, got 1"),
        ({"spread_grid": (0, 4)}, r"spread_grid\[0\] \(rows\) must be an integer with 1 <= .* <= 64, got 0"),
        ({"spread_grid": 8}, r"spread_grid must be a \(rows, cols\) pair of integers in \[1, 64\], got 8"),
        ({"forward_backward": "yes"}, r"forward_backward must be True or False, got 'yes'"),
        ({"fb_max_error_px": -1.0}, r"fb_max_error_px must be a positive finite number"),
        (
            {"normalize_brightness": None},
            r"normalize_brightness must be one of 'pair', 'frame', 'off' \(or True/False\), got None",
        ),
        (
            {"normalize_brightness": "auto"},
            r"normalize_brightness must be one of 'pair', 'frame', 'off'.*got 'auto'",
        ),
        ({"min_parallax_px": -0.5}, r"min_parallax_px must be a finite number >= 0"),
        ({"min_parallax_px": float("inf")}, r"min_parallax_px must be a finite number >= 0"),
        ({"max_epipolar_error_px": 0}, r"max_epipolar_error_px must be a positive finite number"),
    ],
)
def test_bad_parameters_name_the_parameter_value_and_range(kwargs, message):
    with pytest.raises(ValueError, match=message):
        FlowDepthEstimator(SMALL, **kwargs)


def test_intrinsics_must_be_camera_intrinsics():
    with pytest.raises(ValueError, match=r"intrinsics must be a CameraIntrinsics, got ndarray"):
        FlowDepthEstimator(np.eye(3))  # type: ignore[arg-type]


_IMAGE = np.zeros((48, 64), np.uint8)
_SCALED_ROTATION = 1.1 * np.eye(3)
_REFLECTION = np.diag([1.0, 1.0, -1.0])


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        ((_IMAGE.astype(np.float32), _IMAGE, np.eye(3), np.zeros(3)), r"prev_image must have dtype uint8"),
        ((_IMAGE, _IMAGE[:, :, None], np.eye(3), np.zeros(3)), r"next_image must have shape \(H, W\) or"),
        (
            (_IMAGE, np.zeros((48, 63), np.uint8), np.eye(3), np.zeros(3)),
            r"prev_image and next_image must have the same size, got 64x48 and 63x48",
        ),
        (
            (np.zeros((40, 60), np.uint8),) * 2 + (np.eye(3), np.zeros(3)),
            r"prev_image must be 64x48 \(width x height\) to match the camera intrinsics, got 60x40",
        ),
        (
            (_IMAGE, _IMAGE, np.eye(2), np.zeros(3)),
            r"rotation must be a 3x3 rotation matrix, got .* \(2, 2\)",
        ),
        ((_IMAGE, _IMAGE, _SCALED_ROTATION, np.zeros(3)), r"rotation must be a rotation matrix \(R\^T R = I"),
        ((_IMAGE, _IMAGE, _REFLECTION, np.zeros(3)), r"rotation must be a rotation matrix .* det R = -1"),
        ((_IMAGE, _IMAGE, np.full((3, 3), np.nan), np.zeros(3)), r"rotation must be a finite 3x3 rotation"),
        ((_IMAGE, _IMAGE, "identity", np.zeros(3)), r"rotation must be a 3x3 rotation matrix"),
        ((_IMAGE, _IMAGE, np.eye(3), [0.0, np.inf, 0.0]), r"translation must be a finite 3-vector in metres"),
        (
            (_IMAGE, _IMAGE, np.eye(3), np.zeros(4)),
            r"translation must be a finite 3-vector in metres, got .* \(4,\)",
        ),
    ],
)
def test_estimate_rejects_bad_input(arguments, message):
    with pytest.raises(ValueError, match=message):
        FlowDepthEstimator(SMALL).estimate(*arguments)


def test_update_rejects_bad_input_and_keeps_its_state():
    estimator = FlowDepthEstimator(SMALL)
    with pytest.raises(ValueError, match=r"image must be 64x48 \(width x height\)"):
        estimator.update(np.zeros((48, 48), np.uint8), np.eye(3), np.zeros(3))
    with pytest.raises(ValueError, match=r"translation must be a finite 3-vector"):
        estimator.update(_IMAGE, np.eye(3), [np.nan, 0.0, 0.0])
    # Neither bad call became the previous frame.
    assert estimator.update(_IMAGE, np.eye(3), np.zeros(3)).num_points == 0
