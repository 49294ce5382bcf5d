"""flownav_env.rotations: quaternion and axis-angle round trips, slerp, the level camera's axes."""

from __future__ import annotations

import numpy as np

from flownav_env.rotations import (
    camera_rotation,
    matrix_from_quat,
    quat_from_matrix,
    rotation_from_vector,
    slerp,
    vector_from_rotation,
)


def test_quaternion_round_trip_and_slerp() -> None:
    rotation = rotation_from_vector([0.3, -1.2, 2.9])
    np.testing.assert_allclose(matrix_from_quat(quat_from_matrix(rotation)), rotation, atol=1e-12)
    start, end = np.eye(3), rotation_from_vector([0.0, 0.0, 1.0])
    middle = matrix_from_quat(slerp(quat_from_matrix(start), quat_from_matrix(end), 0.5))
    np.testing.assert_allclose(middle, rotation_from_vector([0.0, 0.0, 0.5]), atol=1e-12)
    # q and -q are one rotation: slerp must take the short way, not a 2π detour.
    q = quat_from_matrix(end)
    np.testing.assert_allclose(matrix_from_quat(slerp(q, -quat_from_matrix(start), 0.5)), middle, atol=1e-12)


def test_axis_angle_round_trip_and_batched_quaternions() -> None:
    vector = np.array([0.2, -0.4, 0.1])
    np.testing.assert_allclose(vector_from_rotation(rotation_from_vector(vector)), vector, atol=1e-12)
    rotations = np.array([rotation_from_vector([0, 0, a]) for a in (0.0, 1.0, 3.0)])
    np.testing.assert_allclose(matrix_from_quat(quat_from_matrix(rotations)), rotations, atol=1e-12)
    assert np.all(quat_from_matrix(rotations)[:, 0] >= 0)


def test_level_camera_looks_along_its_heading() -> None:
    rotation = camera_rotation(np.pi / 2)
    np.testing.assert_allclose(rotation[:, 2], [0.0, 1.0, 0.0], atol=1e-12)  # forward = world +y
    np.testing.assert_allclose(rotation[:, 1], [0.0, 0.0, -1.0], atol=1e-12)  # image down = world down
    np.testing.assert_allclose(np.linalg.det(rotation), 1.0)
