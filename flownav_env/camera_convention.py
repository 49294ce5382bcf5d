"""The one boundary between MuJoCo's camera convention and the estimator's (OpenCV) convention.

MuJoCo cameras look along their −z axis with +y up; the estimator's camera frame is OpenCV's: x right, y down,
z forward. Both share x, so the conversion is a rotation by π about x, applied here and nowhere else.
"""

from __future__ import annotations

import numpy as np

MUJOCO_FROM_OPENCV = np.diag([1.0, -1.0, -1.0])


def opencv_camera_pose(cam_xmat: np.ndarray, cam_xpos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World pose of a MuJoCo camera in OpenCV axes.

    Args:
        cam_xmat: MuJoCo's ``data.cam_xmat[i]`` (9,) or (3, 3): world-from-camera rotation, MuJoCo axes.
        cam_xpos: ``data.cam_xpos[i]`` (3,): camera position in the world, m.

    Returns:
        (R, p): world-from-camera rotation in OpenCV axes (3, 3) and the position (3,), both copies.
    """
    rotation = np.asarray(cam_xmat, np.float64).reshape(3, 3) @ MUJOCO_FROM_OPENCV
    return rotation, np.array(cam_xpos, np.float64)


def camera_motion_between(
    rotation_prev: np.ndarray, position_prev: np.ndarray, rotation_next: np.ndarray, position_next: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Motion between two camera poses as the estimator wants it: ``X_next = R @ X_prev + t``.

    Not :func:`estimator.accuracy.relative_motion`, which takes 4×4 camera-to-world matrices.

    Args:
        rotation_prev, rotation_next: world-from-camera rotations (3, 3).
        position_prev, position_next: camera positions in the world (3,).

    Returns:
        (R, t): rotation (3, 3) and translation (3,) in metres.
    """
    rotation = rotation_next.T @ rotation_prev
    translation = rotation_next.T @ (position_prev - position_next)
    return rotation, translation
