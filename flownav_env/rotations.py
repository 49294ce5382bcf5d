"""Rotation helpers shared by the env, the sensor model and playback: quaternions, slerp, axis-angle vectors
and the level camera's orientation. Plain numpy (and cv2.Rodrigues); no MuJoCo.

Quaternions are ``(w, x, y, z)``; camera rotations are world-from-camera with OpenCV camera axes (x right,
y down, z forward) in a world with x forward, y left, z up.
"""

from __future__ import annotations

import math

import cv2
import numpy as np


def rotation_from_vector(rotation_vector: np.ndarray) -> np.ndarray:
    """Rotation matrix of an axis-angle vector (radians)."""
    matrix, _ = cv2.Rodrigues(np.asarray(rotation_vector, np.float64).reshape(3, 1))
    return matrix


def vector_from_rotation(rotation: np.ndarray) -> np.ndarray:
    """Axis-angle vector (radians) of a rotation matrix."""
    vector, _ = cv2.Rodrigues(np.asarray(rotation, np.float64))
    return vector.reshape(3)


def quat_from_matrix(rotation: np.ndarray) -> np.ndarray:
    """Unit quaternion ``(w, x, y, z)`` with ``w >= 0`` of a rotation matrix (Shepperd's method).

    Args:
        rotation: (3, 3) rotation matrix, or (N, 3, 3).

    Returns:
        (4,) or (N, 4) float64 quaternions.
    """
    matrices = np.asarray(rotation, np.float64).reshape(-1, 3, 3)
    quats = np.empty((len(matrices), 4))
    for i, m in enumerate(matrices):
        trace = m[0, 0] + m[1, 1] + m[2, 2]
        # Branch on the largest diagonal term so the square root never sees a tiny, cancellation-prone value.
        if trace > 0.0:
            s = 2.0 * math.sqrt(1.0 + trace)
            q = [0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
        elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
            s = 2.0 * math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
            q = [(m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s]
        elif m[1, 1] > m[2, 2]:
            s = 2.0 * math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
            q = [(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s]
        else:
            s = 2.0 * math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
            q = [(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s]
        unit = np.asarray(q)
        unit /= np.linalg.norm(unit)
        quats[i] = -unit if unit[0] < 0 else unit
    return quats[0] if np.ndim(rotation) == 2 else quats


def matrix_from_quat(quaternion: np.ndarray) -> np.ndarray:
    """Rotation matrix of a quaternion ``(w, x, y, z)`` (normalised first); (4,) → (3, 3), (N, 4) → (N, 3, 3)."""
    q = np.asarray(quaternion, np.float64)
    single = q.ndim == 1
    q = q.reshape(-1, 4)
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    w, x, y, z = q.T
    matrices = np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1),
        ],
        axis=-2,
    )
    return matrices[0] if single else matrices


def slerp(q0: np.ndarray, q1: np.ndarray, fraction: np.ndarray | float) -> np.ndarray:
    """Spherical linear interpolation between unit quaternions along the shorter arc.

    Args:
        q0: (4,) or (N, 4) start quaternions ``(w, x, y, z)``.
        q1: Same shape, end quaternions.
        fraction: Scalar or (N,) interpolation parameter in [0, 1]; 0 gives ``q0``, 1 gives ``q1`` (up to sign).

    Returns:
        Interpolated unit quaternions, the shape of ``q0``.
    """
    a = np.atleast_2d(np.asarray(q0, np.float64))
    b = np.atleast_2d(np.asarray(q1, np.float64)).copy()
    u = np.broadcast_to(np.asarray(fraction, np.float64), (len(a),))[:, None]
    dot = np.sum(a * b, axis=1, keepdims=True)
    # q and -q are the same rotation: flip one so the interpolation takes the short way round.
    b = np.where(dot < 0.0, -b, b)
    dot = np.abs(dot)
    angle = np.arccos(np.clip(dot, -1.0, 1.0))
    sin_angle = np.sin(angle)
    # Nearly equal quaternions: the slerp weights are 0/0; linear interpolation is exact to first order there.
    close = sin_angle < 1e-9
    safe_sin = np.where(close, 1.0, sin_angle)
    w0 = np.where(close, 1.0 - u, np.sin((1.0 - u) * angle) / safe_sin)
    w1 = np.where(close, u, np.sin(u * angle) / safe_sin)
    result = w0 * a + w1 * b
    result /= np.linalg.norm(result, axis=1, keepdims=True)
    return result[0] if np.ndim(q0) == 1 else result


def camera_rotation(heading: float, local: np.ndarray | None = None) -> np.ndarray:
    """World-from-camera rotation (OpenCV axes) of a level camera looking along world heading ``heading``.

    Args:
        heading: Angle in radians of the viewing direction in the world's horizontal plane, counter-clockwise
            from +x (0 looks along +x).
        local: Optional (3, 3) extra rotation in the camera's own axes (applied after levelling), e.g.
            :func:`rotation_from_vector` of roll/pitch/yaw offsets.

    Returns:
        (3, 3) rotation whose columns are the camera's x (right), y (down) and z (forward) axes in the world.
    """
    forward = np.array([math.cos(heading), math.sin(heading), 0.0])
    right = np.array([math.sin(heading), -math.cos(heading), 0.0])
    down = np.array([0.0, 0.0, -1.0])
    level = np.column_stack([right, down, forward])
    return level if local is None else level @ np.asarray(local, np.float64)
