"""Sensor model: what the drone believes about its own motion, and the camera-mount vibration.

These are the thesis's test variables (§5.2.1, §5.2.4–5.2.5): attitude jitter is a real disturbance of the
camera that the system knows about; rotation and translation errors corrupt only what the estimator is told.
"""

from __future__ import annotations

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


def corrupt_motion(
    rotation: np.ndarray,
    translation: np.ndarray,
    rotation_error: float,
    translation_error: float,
    rng: np.random.Generator,
) -> tuple[np.ndarray, np.ndarray]:
    """The motion the estimator is told: each component off by up to the given relative error.

    As in the thesis, an error of 0.04 scales every component of the rotation (as an axis-angle vector) and of
    the translation by an independent factor drawn uniformly from [0.96, 1.04].

    Args:
        rotation: true relative rotation (3, 3).
        translation: true relative translation (3,), m.
        rotation_error: largest relative error of each rotation component, in [0, 1].
        translation_error: largest relative error of each translation component, in [0, 1].
        rng: the episode's generator.

    Returns:
        (R, t) as told to the estimator. With both errors zero the inputs come back unchanged (no draw).
    """
    if rotation_error > 0:
        scale = 1.0 + rng.uniform(-rotation_error, rotation_error, 3)
        rotation = rotation_from_vector(vector_from_rotation(rotation) * scale)
    if translation_error > 0:
        translation = translation * (1.0 + rng.uniform(-translation_error, translation_error, 3))
    return rotation, translation


def jitter_rotation(jitter_deg: float, rng: np.random.Generator) -> np.ndarray:
    """A random camera-mount disturbance: roll, pitch and yaw each uniform in ±``jitter_deg``."""
    if jitter_deg <= 0:
        return np.eye(3)
    return rotation_from_vector(np.deg2rad(rng.uniform(-jitter_deg, jitter_deg, 3)))
