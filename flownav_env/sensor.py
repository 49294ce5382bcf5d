"""Sensor model: what the drone believes about its own motion, the camera-mount vibration, and the per-frame
sensing order that the env and playback share.

These are the thesis's test variables (§5.2.1, §5.2.4–5.2.5): attitude jitter is a real disturbance of the
camera that the system knows about; rotation and translation errors corrupt only what the estimator is told.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

from flownav_env.camera import camera_motion_between
from flownav_env.rotations import rotation_from_vector, vector_from_rotation
from flownav_env.settings import SensorSettings

Pose = tuple[np.ndarray, np.ndarray]


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
    """A random camera-mount disturbance: roll, pitch and yaw each uniform in ±``jitter_deg`` (no draw at 0)."""
    if jitter_deg <= 0:
        return np.eye(3)
    return rotation_from_vector(np.deg2rad(rng.uniform(-jitter_deg, jitter_deg, 3)))


@dataclass(frozen=True)
class SensorFrame:
    """One captured camera frame and the motion that led to it.

    Attributes:
        image: RGB frame (H, W, 3) uint8.
        gray: The same frame in grey levels (H, W) uint8, what the estimator reads.
        pose: ``(R, p)``: world-from-camera rotation (OpenCV axes, jitter included) and position it was
            rendered from.
        previous_pose: The pose of the frame before (``pose`` itself on a first frame).
        true_motion: ``(R, t)`` from the previous camera to this one (``X_this = R X_prev + t``); identity
            and zero on a first frame.
        told_motion: What the estimator is told: ``true_motion`` with the rotation and translation errors.
    """

    image: np.ndarray
    gray: np.ndarray
    pose: Pose
    previous_pose: Pose
    true_motion: Pose
    told_motion: Pose


class SensorPipeline:
    """The per-frame sensing order, written once for the env and for playback.

    Per frame: draw the attitude jitter, move the camera (the caller decides how: fly the drone or place it),
    render, take the true motion since the previous captured frame, corrupt it into the told motion. The
    random draws (jitter, then the errors) come in this order from the caller's generator, so a seed fixes
    them. Feeding the estimator stays with the caller, which may run several estimators on one frame.
    """

    def __init__(self) -> None:
        self._previous_pose: Pose | None = None

    def capture(
        self,
        sensor: SensorSettings,
        rng: np.random.Generator,
        move_camera: Callable[[np.ndarray], Pose],
        render: Callable[[], np.ndarray],
        first: bool,
    ) -> SensorFrame:
        """Capture one frame.

        Args:
            sensor: The sensor variables for this frame.
            rng: The generator of the jitter and the motion errors.
            move_camera: Moves the camera for this frame with the given (3, 3) jitter rotation (in the
                camera's own axes) and returns the camera's resulting world pose ``(R, p)``.
            render: Renders the RGB frame from the camera's current pose.
            first: Whether this frame starts a sequence (no previous frame: no motion, no error draws).

        Raises:
            ValueError: ``first`` is False but no frame was captured before.
        """
        if not first and self._previous_pose is None:
            raise ValueError("the first frame of a sequence must be captured with first=True")
        pose = move_camera(jitter_rotation(sensor.attitude_jitter_deg, rng))
        image = render()
        if first:
            previous = pose
            true_motion = told_motion = (np.eye(3), np.zeros(3))
        else:
            previous = self._previous_pose
            true_motion = camera_motion_between(*previous, *pose)
            told_motion = corrupt_motion(*true_motion, sensor.rotation_error, sensor.translation_error, rng)
        self._previous_pose = pose
        gray = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)
        return SensorFrame(image, gray, pose, previous, true_motion, told_motion)
