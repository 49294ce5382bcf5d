"""The thesis's Unity angles in FlowNav's camera axes, and a rotation error applied to the camera's absolute
attitude instead of its per-frame rotation.

Unity's axes are x right, y up, z forward (left-handed); FlowNav's camera axes are OpenCV's: x right, y down,
z forward (right-handed). Unity's positive rotations use its standard matrices in its own (left-handed) axes,
so +x tilts the view down, +y turns it right and +z rolls it counter-clockwise as seen from behind the camera.
Flipping the y axis maps one frame onto the other, which turns a Unity rotation of θ about x, y, z into one of
−θ, +θ, −θ about FlowNav's camera x, y, z: Unity ``(x, y, z)`` = FlowNav ``(−pitch, yaw, −roll)``, where
FlowNav's positive pitch looks up, positive yaw right and positive roll turns the right side down.
``Quaternion.Euler(x, y, z)`` rotates about z first, then x, then y (about fixed axes), so the attitude is
``Ry(yaw) @ Rx(pitch) @ Rz(roll)`` in camera axes.
"""

from __future__ import annotations

import math

import numpy as np

from estimator.geometry import euler_zyx_to_rotation
from flownav_env.rotations import camera_rotation

# (pitch, yaw, roll) in FlowNav = UNITY_SIGNS * (x, y, z) in Unity; the map is its own inverse.
UNITY_SIGNS = np.array([-1.0, 1.0, -1.0])


def unity_to_camera_deg(unity_deg: list[float] | np.ndarray) -> tuple[float, float, float]:
    """FlowNav ``(pitch, yaw, roll)`` in degrees of a Unity rotation ``(x, y, z)`` in degrees."""
    pitch, yaw, roll = UNITY_SIGNS * np.asarray(unity_deg, np.float64)
    return float(pitch), float(yaw), float(roll)


def unity_order_rotation(pitch: float, yaw: float, roll: float) -> np.ndarray:
    """``Ry(yaw) @ Rx(pitch) @ Rz(roll)`` in camera axes (radians): Unity's Euler order (the thesis's eq. 4.15
    order, ``Rz(roll) @ Ry(yaw) @ Rx(pitch)``, is :func:`estimator.geometry.euler_zyx_to_rotation`)."""
    return (
        euler_zyx_to_rotation(0.0, yaw, 0.0)
        @ euler_zyx_to_rotation(pitch, 0.0, 0.0)
        @ euler_zyx_to_rotation(0.0, 0.0, roll)
    )


def unity_angles(local: np.ndarray) -> np.ndarray:
    """``(pitch, yaw, roll)`` in radians with ``local = unity_order_rotation(pitch, yaw, roll)``.

    Pitch lies in [−π/2, π/2], yaw and roll in (−π, π]; the signed angles, not Unity's [0°, 360°) readout.
    """
    pitch = math.asin(float(np.clip(-local[1, 2], -1.0, 1.0)))
    yaw = math.atan2(local[0, 2], local[2, 2])
    roll = math.atan2(local[1, 0], local[1, 1])
    return np.array([pitch, yaw, roll])


class AttitudeRotationError:
    """Told rotations built from absolute attitudes whose Euler angles each carry a relative error.

    The thesis's rotation-input error is "random, up to x %" of the rotation it tells the system. FlowNav's
    ``rotation_error`` scales the per-frame rotation; this reading scales each absolute attitude angle (relative
    to a level camera looking along world +x, as Unity reports a transform's angles) by its own factor in
    [1 − error, 1 + error], drawn once per frame, and tells the rotation between two such attitudes. The
    per-frame error then grows with the attitude, not with the motion between frames.

    Args:
        error: Largest relative error of each angle, in [0, 1].
        rng: The generator of the factors.
    """

    def __init__(self, error: float, rng: np.random.Generator) -> None:
        if not 0.0 <= error <= 1.0:
            raise ValueError(f"error must be in [0, 1], got {error!r}")
        self.error = error
        self.rng = rng
        self._level = camera_rotation(0.0)
        self._previous: np.ndarray | None = None

    def told_rotation(self, rotation: np.ndarray, first: bool) -> np.ndarray:
        """The rotation from the previous frame's told attitude to this one's (identity on a first frame).

        Args:
            rotation: This frame's true world-from-camera rotation (OpenCV camera axes).
            first: Whether this frame starts a sequence.
        """
        angles = unity_angles(self._level.T @ rotation)
        if self.error > 0:
            angles = angles * (1.0 + self.rng.uniform(-self.error, self.error, 3))
        told = self._level @ unity_order_rotation(*angles)
        relative = np.eye(3) if first or self._previous is None else told.T @ self._previous
        self._previous = told
        return relative
