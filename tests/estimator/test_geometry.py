"""Analytic tests of estimator.geometry: exact correspondences from known 3-D points and motion."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from estimator import CameraIntrinsics
from estimator.geometry import (
    METHODS,
    derotate,
    euler_zyx_to_rotation,
    predict_next_pixels,
    project_points,
    rotation_to_euler_zyx,
    solve_depth,
    valid_depth_mask,
)

INTRINSICS = CameraIntrinsics.from_fov(640, 480, 60.0)
FOCAL = INTRINSICS.focal_scale
EXACT = 1e-6  # relative depth tolerance for exact correspondences


def _rotation(axis: str, degrees: float) -> np.ndarray:
    angle = np.radians(degrees)
    roll, pitch, yaw = (angle if axis == name else 0.0 for name in "xyz")
    return euler_zyx_to_rotation(roll, pitch, yaw)


def _compose(*rotations: np.ndarray) -> np.ndarray:
    result = np.eye(3)
    for rotation in rotations:
        result = rotation @ result
    return result


def _random_rotation(rng: np.random.Generator, max_degrees: float) -> np.ndarray:
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    angle = np.radians(rng.uniform(-max_degrees, max_degrees))
    skew = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + np.sin(angle) * skew + (1.0 - np.cos(angle)) * skew @ skew


def _scene(rotation: np.ndarray, translation: np.ndarray, count: int = 400, seed: int = 0):
    """Random static points seen in both images: normalised coordinates before/after and true depth."""
    rng = np.random.default_rng(seed)
    pixels = rng.uniform([20.0, 20.0], [619.0, 459.0], size=(count, 2))
    depth = rng.uniform(0.5, 15.0, size=count)
    normalized_prev = INTRINSICS.normalize(pixels)
    points_prev = depth[:, None] * np.column_stack([normalized_prev, np.ones(count)])
    points_next = points_prev @ rotation.T + translation
    return normalized_prev, project_points(points_next), depth


def _assert_exact_depth(rotation, translation, method, min_parallax_px=0.5):
    normalized_prev, normalized_next, depth = _scene(rotation, translation)
    solution = solve_depth(normalized_prev, normalized_next, rotation, translation, FOCAL, method)
    valid = valid_depth_mask(solution, min_parallax_px=min_parallax_px, max_epipolar_error_px=1e-6)
    assert valid.mean() > 0.9
    np.testing.assert_allclose(solution.depth[valid], depth[valid], rtol=EXACT)
    return solution, valid


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize(
    "translation",
    [[0.1, 0.0, 0.0], [-0.1, 0.0, 0.0], [0.0, 0.1, 0.0], [0.0, 0.0, 0.1], [0.0, 0.0, -0.1]],
    ids=["+x", "-x", "+y", "+z", "-z"],
)
def test_pure_translation_recovers_exact_depth(translation, method):
    _assert_exact_depth(np.eye(3), np.array(translation), method)


def test_pure_x_translation_is_thesis_eq_4_18():
    # Moving along x only: depth = t_x / flow_x (flow in normalised units).
    translation = np.array([0.2, 0.0, 0.0])
    normalized_prev, normalized_next, depth = _scene(np.eye(3), translation)
    np.testing.assert_allclose(translation[0] / (normalized_next[:, 0] - normalized_prev[:, 0]), depth)
    solution = solve_depth(normalized_prev, normalized_next, np.eye(3), translation, FOCAL, "thesis")
    np.testing.assert_allclose(solution.depth, depth, rtol=EXACT)


def test_pure_z_translation_is_thesis_eq_4_12():
    # Moving along z only: depth = (offset from the focus of expansion) × (distance travelled) / flow, with
    # the focus of expansion at the principal point and the offset measured in the next image.
    translation = np.array([0.0, 0.0, -0.3])
    normalized_prev, normalized_next, depth = _scene(np.eye(3), translation)
    flow = normalized_next - normalized_prev
    larger = np.argmax(np.abs(flow), axis=1)
    rows = np.arange(len(depth))
    eq_4_12 = normalized_next[rows, larger] * -translation[2] / flow[rows, larger]
    np.testing.assert_allclose(eq_4_12, depth)
    solution = solve_depth(normalized_prev, normalized_next, np.eye(3), translation, FOCAL, "thesis")
    np.testing.assert_allclose(solution.depth, depth, rtol=EXACT)


@pytest.mark.parametrize("method", METHODS)
def test_pure_rotation_derotates_exactly_and_gives_no_depth(method):
    rotation = _compose(_rotation("x", 4.0), _rotation("y", -3.0), _rotation("z", 10.0))
    normalized_prev, normalized_next, _ = _scene(rotation, np.zeros(3))
    derotated, _ = derotate(normalized_prev, rotation)
    residual_px = np.abs((normalized_next - derotated) * FOCAL)
    assert residual_px.max() < 1e-9
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        solution = solve_depth(normalized_prev, normalized_next, rotation, np.zeros(3), FOCAL, method)
        valid = valid_depth_mask(solution, min_parallax_px=1.0, max_epipolar_error_px=1.0)
    assert not valid.any()
    assert solution.parallax_px.max() < 1e-9


# Thesis Table 2 exercises the rotation compensation with rotations about each axis and their
# combinations. Our nine cases: each axis in both directions, each pair of axes, and all three.
TABLE_2_ROTATIONS = {
    "+x": _rotation("x", 5.0),
    "-x": _rotation("x", -5.0),
    "+y": _rotation("y", 5.0),
    "-y": _rotation("y", -5.0),
    "+z": _rotation("z", 5.0),
    "-z": _rotation("z", -5.0),
    "x+y": _compose(_rotation("x", 4.0), _rotation("y", -3.0)),
    "y+z": _compose(_rotation("y", 3.0), _rotation("z", 6.0)),
    "x+y+z": _compose(_rotation("x", -3.0), _rotation("y", 4.0), _rotation("z", -5.0)),
}


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("case", TABLE_2_ROTATIONS, ids=list(TABLE_2_ROTATIONS))
def test_table_2_rotations_with_translation_recover_exact_depth(case, method):
    rotation = TABLE_2_ROTATIONS[case]
    # Rotation alone: the derotation explains the whole flow.
    normalized_prev, normalized_next, _ = _scene(rotation, np.zeros(3))
    derotated, _ = derotate(normalized_prev, rotation)
    assert np.abs((normalized_next - derotated) * FOCAL).max() < 1e-9
    # With a forward-and-sideways translation on top, depth is exact.
    _assert_exact_depth(rotation, np.array([0.05, -0.03, 0.2]), method)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("seed", range(5))
def test_arbitrary_6dof_motion_recovers_exact_depth(seed, method):
    rng = np.random.default_rng(100 + seed)
    rotation = _random_rotation(rng, max_degrees=10.0)
    translation = rng.uniform(-0.3, 0.3, size=3)
    _assert_exact_depth(rotation, translation, method)


def test_euler_round_trip_including_gimbal_lock():
    rng = np.random.default_rng(7)
    rotations = [_random_rotation(rng, 180.0) for _ in range(50)]
    rotations += [euler_zyx_to_rotation(0.3, np.pi / 2, -0.2), euler_zyx_to_rotation(0.1, -np.pi / 2, 0.4)]
    for rotation in rotations:
        rebuilt = euler_zyx_to_rotation(*rotation_to_euler_zyx(rotation))
        np.testing.assert_allclose(rebuilt, rotation, atol=1e-9)


def test_off_epipolar_error_is_measured_and_rejected():
    translation = np.array([0.1, 0.0, 0.0])
    normalized_prev, normalized_next, _ = _scene(np.eye(3), translation)
    # Pure x motion: the flow must be horizontal, so a 3 px vertical shift is entirely epipolar error.
    shifted = normalized_next + np.array([0.0, 3.0]) / FOCAL
    solution = solve_depth(normalized_prev, shifted, np.eye(3), translation, FOCAL)
    np.testing.assert_allclose(solution.epipolar_error_px, 3.0, rtol=1e-9)
    assert not valid_depth_mask(solution, min_parallax_px=0.5, max_epipolar_error_px=1.0).any()


def test_flow_against_the_motion_is_invalid():
    # Flow pointing the wrong way along the epipolar line means a point behind a camera: negative depth.
    translation = np.array([0.1, 0.0, 0.0])
    normalized_prev, normalized_next, _ = _scene(np.eye(3), translation)
    reversed_next = 2 * normalized_prev - normalized_next
    solution = solve_depth(normalized_prev, reversed_next, np.eye(3), translation, FOCAL)
    assert np.all(solution.depth < 0)
    assert not valid_depth_mask(solution, min_parallax_px=0.5, max_epipolar_error_px=1.0).any()


@pytest.mark.parametrize("method", METHODS)
def test_hovering_and_focus_of_expansion_are_invalid_without_warnings(method):
    rng = np.random.default_rng(1)
    normalized = INTRINSICS.normalize(rng.uniform(0, 639, size=(100, 2)))
    normalized[0] = 0.0  # exactly at the focus of expansion of a z motion
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for translation in (np.zeros(3), np.array([0.0, 0.0, 0.1]), np.array([1e-7, 0.0, 0.0])):
            solution = solve_depth(normalized, normalized, np.eye(3), translation, FOCAL, method)
            assert not valid_depth_mask(solution, 1.0, 1.0).any()
        # A ray rotated behind the camera (a 120° turn) has no derotated position.
        solution = solve_depth(normalized, normalized, _rotation("y", 120.0), np.ones(3), FOCAL, method)
        assert not valid_depth_mask(solution, 1.0, 1.0).any()


def test_empty_input():
    solution = solve_depth(np.empty((0, 2)), np.empty((0, 2)), np.eye(3), np.ones(3), FOCAL, "thesis")
    assert solution.depth.shape == (0,)
    assert valid_depth_mask(solution, 1.0, 1.0).shape == (0,)


def test_predict_next_pixels_matches_projection():
    rotation = TABLE_2_ROTATIONS["x+y+z"]
    translation = np.array([0.1, 0.05, -0.2])
    normalized_prev, normalized_next, depth = _scene(rotation, translation)
    predicted = predict_next_pixels(
        INTRINSICS.denormalize(normalized_prev), depth, rotation, translation, INTRINSICS.matrix
    )
    np.testing.assert_allclose(predicted, INTRINSICS.denormalize(normalized_next), atol=1e-9)


def test_unknown_method_is_rejected():
    with pytest.raises(ValueError, match=r"method must be one of \('triangulation', 'thesis'\), got 'sfm'"):
        solve_depth(np.zeros((1, 2)), np.zeros((1, 2)), np.eye(3), np.ones(3), FOCAL, "sfm")
