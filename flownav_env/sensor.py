"""Sensor model: what the drone believes about its own motion, the camera-mount vibration, and the per-frame
sensing order that the env and playback share.

These are the thesis's test variables (§5.2.1, §5.2.4–5.2.5): attitude jitter is a real disturbance of the
camera that the system knows about; rotation and translation errors corrupt only what the estimator is told.
Beside them, the error models of real sensors (defined, with their maths, in :mod:`flownav_env.sensor_errors`):
a constant or drifting scale bias and an absolute noise floor on the told motion, and noise, outliers and
dropout on the estimated depths.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from estimator import DepthPoints
from flownav_env.camera_convention import camera_motion_between
from flownav_env.rotations import rotation_from_vector, vector_from_rotation
from flownav_env.sensor_errors import (
    add_motion_noise,
    corrupt_depths,
    gauss_markov_step,
    lagged_attitude,
    outlier_depth_range,
    scale_motion,
    walk_bias,
)
from flownav_env.settings import BIAS_LIMIT, EnvSettings, SensorSettings

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
class FrameMotion:
    """The camera's motion up to one frame: the truth and what the estimator is told.

    Attributes:
        pose: ``(R, p)``: world-from-camera rotation (OpenCV axes, jitter included) and position of the frame.
        previous_pose: The pose of the frame before (``pose`` itself on a first frame).
        true_motion: ``(R, t)`` from the previous camera to this one (``X_this = R X_prev + t``); identity
            and zero on a first frame.
        told_motion: What the estimator is told: ``true_motion`` with the relative errors, the bias and the
            noise floor.
        bias: The ``(rotation, translation)`` scale bias applied to ``told_motion`` (0 on a first frame).
    """

    pose: Pose
    previous_pose: Pose
    true_motion: Pose
    told_motion: Pose
    bias: tuple[float, float] = (0.0, 0.0)


class SensorPipeline:
    """The sensor's part of each frame, written once for the env and for playback, which call it in this order:

    1. :meth:`jitter`: draw the camera mount's disturbance; the caller turns the camera by it as it moves the
       camera (flies the drone, or places it), then renders the frame;
    2. :meth:`start` (a sequence's first frame) or :meth:`motion`: the true motion since the previous frame
       and the told motion, with its errors;
    3. the caller feeds the estimator (it may run several on one frame); the env then passes the estimated
       depths through the depth errors (:meth:`corrupt_points`) before the histogram.

    The random draws come in this order from the caller's generator, so a seed fixes them: jitter, relative
    errors, bias walk (rotation, translation), noise floor (rotation, translation: white, or the next step of
    its time-correlated process), then depth noise,
    outliers and dropout; each only when its setting is non-zero. Nothing here moves or renders the camera.

    The per-episode state is the random walk of the biases (:mod:`flownav_env.sensor_errors`), restarted
    at 0 by every first frame (the applied bias is the current ``rotation_bias``/``translation_bias`` setting
    plus the walk, clipped to ±:data:`~flownav_env.settings.BIAS_LIMIT`), and the time-correlated translation
    noise's last value, drawn afresh from its stationary distribution after every first frame.

    Args:
        frame_rate: Frames per second of the captured sequence, Hz: a bias's walk steps every 1/frame_rate s.

    Raises:
        ValueError: ``frame_rate`` is not positive.
    """

    def __init__(self, frame_rate: float = 10.0) -> None:
        if not frame_rate > 0:
            raise ValueError(f"frame_rate must be > 0 Hz, got {frame_rate!r}")
        self.frame_interval = 1.0 / frame_rate
        self._previous_pose: Pose | None = None
        # Set with the pose by start(); motion() refuses to run before it.
        self._previous_told_attitude: np.ndarray = np.eye(3)
        self._walk = (0.0, 0.0)
        # The time-correlated translation noise's last value (world axes, m per frame); None before its first.
        self._velocity_error: np.ndarray | None = None

    @staticmethod
    def jitter(sensor: SensorSettings, rng: np.random.Generator) -> np.ndarray:
        """The camera mount's disturbance for the coming frame, a (3, 3) rotation in the camera's own axes
        (:func:`jitter_rotation`; the identity, without a draw, when ``attitude_jitter_deg`` is 0)."""
        return jitter_rotation(sensor.attitude_jitter_deg, rng)

    def start(self, pose: Pose) -> FrameMotion:
        """The first frame of a sequence, taken from ``pose``: no motion, no error draws; the bias walk
        restarts."""
        self._previous_pose, self._walk, self._velocity_error = pose, (0.0, 0.0), None
        self._previous_told_attitude = pose[0]
        still = (np.eye(3), np.zeros(3))
        return FrameMotion(pose, pose, still, still)

    def motion(self, sensor: SensorSettings, rng: np.random.Generator, pose: Pose) -> FrameMotion:
        """The next frame, taken from ``pose``: its true motion since the previous frame and the motion the
        estimator is told (relative errors, bias walk, noise floor; drawn from ``rng`` in that order).

        Raises:
            ValueError: No sequence was started (:meth:`start`).
        """
        previous = self._previous_pose
        if previous is None:
            raise ValueError("a sequence's first frame must go through start() before motion()")
        true_motion = camera_motion_between(*previous, *pose)
        told_motion = true_motion
        if sensor.imu_time_offset_ms > 0:
            lag = sensor.imu_time_offset_ms / 1000.0 / self.frame_interval
            told_attitude = lagged_attitude(previous[0], pose[0], lag)
            told_motion = camera_motion_between(
                self._previous_told_attitude, previous[1], told_attitude, pose[1]
            )
            self._previous_told_attitude = told_attitude
        told_motion = corrupt_motion(*told_motion, sensor.rotation_error, sensor.translation_error, rng)
        bias = self._step_bias(sensor, rng)
        told_motion = scale_motion(*told_motion, 1.0 + bias[0], 1.0 + bias[1])
        correlated = sensor.translation_noise_correlation_s > 0
        white_noise_m = 0.0 if correlated else sensor.translation_noise_m
        told_motion = add_motion_noise(*told_motion, sensor.rotation_noise_deg, white_noise_m, rng)
        if correlated and sensor.translation_noise_m > 0:
            told_motion = self._add_velocity_error(sensor, rng, pose, told_motion)
        self._previous_pose = pose
        return FrameMotion(pose, previous, true_motion, told_motion, bias)

    def _add_velocity_error(
        self, sensor: SensorSettings, rng: np.random.Generator, pose: Pose, motion: Pose
    ) -> Pose:
        """``motion`` with the time-correlated translation noise: the told displacement is off by the
        Gauss-Markov error (world axes), seen in the new camera's axes (``t = R_next^T (p_prev − p_next)``)."""
        self._velocity_error = gauss_markov_step(
            self._velocity_error,
            sensor.translation_noise_m,
            sensor.translation_noise_correlation_s,
            self.frame_interval,
            rng,
        )
        return motion[0], motion[1] - pose[0].T @ self._velocity_error

    def _step_bias(self, sensor: SensorSettings, rng: np.random.Generator) -> tuple[float, float]:
        """Walk the biases one frame on and return the applied ``(rotation, translation)`` bias."""
        interval = self.frame_interval
        self._walk = (
            walk_bias(self._walk[0], sensor.rotation_drift, interval, rng),
            walk_bias(self._walk[1], sensor.translation_drift, interval, rng),
        )
        rotation = min(max(sensor.rotation_bias + self._walk[0], -BIAS_LIMIT), BIAS_LIMIT)
        translation = min(max(sensor.translation_bias + self._walk[1], -BIAS_LIMIT), BIAS_LIMIT)
        return rotation, translation

    def corrupt_points(
        self, settings: EnvSettings, rng: np.random.Generator, points: DepthPoints
    ) -> DepthPoints:
        """The estimator's points with the depth errors on their valid depths, as the observation sees them.

        Only flow observations (``settings.obs_source == "flow"``) get them: the oracles observe true depths.
        The valid depths get :func:`~flownav_env.sensor_errors.corrupt_depths`, the outliers drawn over the
        range of the histogram's bin edges (:func:`~flownav_env.sensor_errors.outlier_depth_range`); a
        dropped point's row is removed altogether, so it is neither counted nor left as a tracked point
        without a depth.

        Returns:
            ``points`` itself when no depth error applies (nothing drawn); else a new :class:`DepthPoints`.
        """
        sensor = settings.sensor
        if settings.obs_source != "flow" or not sensor.depth_errors:
            return points
        valid = np.flatnonzero(points.valid)
        low, high = outlier_depth_range(settings.depth_bin_edges)
        noise, outliers, dropout = sensor.depth_noise, sensor.depth_outliers, sensor.depth_dropout
        depths, keep = corrupt_depths(points.depth[valid], noise, outliers, dropout, low, high, rng)
        depth = points.depth.copy()
        depth[valid] = depths
        rows = np.ones(len(depth), bool)
        rows[valid[~keep]] = False
        return replace(
            points,
            points=points.points[rows],
            next_points=points.next_points[rows],
            depth=depth[rows],
            valid=points.valid[rows],
            tracked=points.tracked[rows],
            parallax_px=points.parallax_px[rows],
        )
