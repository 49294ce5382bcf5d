"""Sensor error models as pure functions on arrays: what the drone is told about its motion, and what the
estimator's depths become before the observation counts them.

The settings that drive them, with their ranges, are the fields of :class:`flownav_env.settings.SensorSettings`;
:class:`flownav_env.sensor.SensorPipeline` applies them in the per-frame order and keeps the one piece of
per-episode state, the drifting bias. Every function takes the episode's generator and draws from it only when
its error is non-zero: at zero the inputs come back unchanged (the same objects) and the generator is
untouched, so at the defaults an episode is the same as before these settings existed. Four kinds of error:

* **Per-frame relative error** (the thesis's): ``rotation_error``, ``translation_error``
  (:func:`flownav_env.sensor.corrupt_motion`).
* **Constant bias** (a mis-calibrated gyro or odometry: a scale error): the told rotation angle (axis
  unchanged) is scaled by ``1 + b_r``, the told translation by ``1 + b_t``, where ``b`` starts at
  ``rotation_bias``/``translation_bias`` at every reset. With ``rotation_drift``/``translation_drift`` > 0
  the bias walks: ``b_k = b + w_k`` with ``w_0 = 0`` at reset and ``w_k = w_{k-1} + N(0, drift² · Δt)``
  drawn before frame k's told motion (Δt = 1/frame_rate s), so ``drift`` is the bias's standard deviation
  after one second of flight. The applied bias is held inside [-0.9, 0.9] (a scale never vanishes or flips
  sign); the walk itself is not.
* **Absolute noise floor** (a gyro is noisy even when the drone does not turn): per frame, a rotation whose
  axis-angle vector is N(0, ``rotation_noise_deg``²) per axis is composed onto the told rotation (on the
  left: in the new camera's axes), and N(0, ``translation_noise_m``²) per axis is added to the told
  translation. Order: relative error, bias, then noise.
* **Time-correlated translation noise** (a flight stack's velocity estimate: its error persists for a while):
  with ``translation_noise_correlation_s`` τ > 0 the noise floor's translation part is not drawn afresh each
  frame but follows :func:`gauss_markov_step`, a first-order Gauss-Markov process with stationary σ
  ``translation_noise_m`` per axis, in the world's axes (where a velocity estimate lives), turned into the
  camera's axes of the frame it is told with. It is drawn where the white translation noise would be.
* **Camera-IMU time offset** (unsynchronised clocks): the attitude told for a frame is the camera's
  ``imu_time_offset_ms`` earlier, interpolated between this frame and the one before (:func:`lagged_attitude`),
  and the told motion is the motion between those lagged attitudes (the positions are the true ones). Turning
  at a steady rate, the lag cancels; a change of turn rate (a manoeuvre, a gust) becomes a rotation error of
  about the change times the offset. It comes first: the other errors act on the lagged motion. No draw.
* **Depth errors**, independent of their cause, on the estimator's valid depths before the histogram (flow
  observations only; the oracles' true depths are left alone): log-normal noise ``depth · exp(N(0,
  depth_noise²))``, then a fraction ``depth_outliers`` replaced by depths drawn log-uniformly over the
  histogram's range (:func:`outlier_depth_range`), then a fraction ``depth_dropout`` removed: those points
  are simply gone (from the histogram, the ``unresolved`` share and ``info``), not counted as tracked points
  without a depth. ``info["points_tracked"]``, ``["points_valid"]`` and ``["depth_error_median"]`` then
  describe the corrupted depths, what the agent sees, so that a sweep's depth error says how wrong the
  observation was (with the errors at 0 they are the estimator's own).
"""

from __future__ import annotations

import math

import numpy as np

from flownav_env.rotations import rotation_from_vector, vector_from_rotation


def scale_motion(
    rotation: np.ndarray, translation: np.ndarray, rotation_scale: float, translation_scale: float
) -> tuple[np.ndarray, np.ndarray]:
    """A motion with its rotation angle and its translation scaled (a bias: ``scale = 1 + bias``).

    The rotation keeps its axis; its angle (the axis-angle vector's length) is multiplied by
    ``rotation_scale``. A scale of exactly 1 leaves its part unchanged (no arithmetic).
    """
    if rotation_scale != 1.0:
        rotation = rotation_from_vector(vector_from_rotation(rotation) * rotation_scale)
    if translation_scale != 1.0:
        translation = translation * translation_scale
    return rotation, translation


def walk_bias(walk: float, drift: float, interval: float, rng: np.random.Generator) -> float:
    """One frame's step of a bias's random walk: ``walk + N(0, drift² · interval)``.

    Args:
        walk: The walk so far (0 at reset).
        drift: Standard deviation after one second, 1/√s; 0 returns ``walk`` without a draw.
        interval: Seconds per frame.
        rng: The episode's generator.
    """
    if drift <= 0:
        return walk
    return walk + float(rng.normal(0.0, drift * math.sqrt(interval)))


def add_motion_noise(
    rotation: np.ndarray,
    translation: np.ndarray,
    rotation_noise_deg: float,
    translation_noise_m: float,
    rng: np.random.Generator,
) -> tuple[np.ndarray, np.ndarray]:
    """A motion with an absolute noise floor: a small random rotation composed onto it, noise added to the
    translation.

    Args:
        rotation: (3, 3) relative rotation.
        translation: (3,) relative translation, m.
        rotation_noise_deg: Standard deviation of each component of the noise rotation's axis-angle vector,
            degrees; the noise rotation is applied after (on the left of) ``rotation``.
        translation_noise_m: Standard deviation of the noise added to each translation component, m.
        rng: The episode's generator (three normal draws per non-zero noise: rotation first).
    """
    if rotation_noise_deg > 0:
        rotation = rotation_from_vector(np.deg2rad(rng.normal(0.0, rotation_noise_deg, 3))) @ rotation
    if translation_noise_m > 0:
        translation = translation + rng.normal(0.0, translation_noise_m, 3)
    return rotation, translation


def gauss_markov_step(
    previous: np.ndarray | None,
    sigma: float,
    correlation_s: float,
    interval: float,
    rng: np.random.Generator,
) -> np.ndarray:
    """One frame's step of a first-order Gauss-Markov process per axis (3,), stationary σ ``sigma``.

    ``e_k = φ e_{k-1} + √(1 − φ²) σ w_k`` with ``φ = exp(−interval / correlation_s)`` and ``w_k ~ N(0, 1)``: the
    error of a velocity estimate, which a flight stack's filter carries from one frame to the next. The first
    frame (``previous`` None) draws from the stationary distribution N(0, σ²), so every frame has the same σ.
    Three normal draws per call.

    Args:
        previous: The last frame's error, or None at an episode's first frame.
        sigma: Stationary standard deviation per axis (> 0).
        correlation_s: Correlation time τ, s (> 0).
        interval: Seconds per frame.
        rng: The episode's generator.
    """
    draw = rng.normal(0.0, sigma, 3)
    if previous is None:
        return draw
    phi = math.exp(-interval / correlation_s)
    return phi * previous + math.sqrt(1.0 - phi * phi) * draw


def outlier_depth_range(bin_edges: tuple[float, ...] | np.ndarray) -> tuple[float, float]:
    """The depths outliers are drawn from (log-uniformly): the histogram's range, from the first bin edge to
    the last.

    A log-uniform draw needs a positive low end; when the first edge is 0 (as in
    :data:`estimator.DEFAULT_BIN_EDGES`) it is half the second edge, so that the first bin still gets its
    share: with the default edges the range is [0.5, 13] m and every bin gets 12–21 % of the outliers.
    """
    edges = np.asarray(bin_edges, np.float64)
    low = float(edges[0]) if edges[0] > 0 else float(edges[1]) / 2.0
    return low, float(edges[-1])


def corrupt_depths(
    depths: np.ndarray,
    noise: float,
    outliers: float,
    dropout: float,
    low: float,
    high: float,
    rng: np.random.Generator,
) -> tuple[np.ndarray, np.ndarray]:
    """Depth errors independent of their cause, on valid depth estimates, in this order:

    1. log-normal noise: each depth times ``exp(N(0, noise²))`` (the log-ratio's standard deviation is
       ``noise``);
    2. outliers: each depth, with probability ``outliers``, replaced by one drawn log-uniformly from
       [``low``, ``high``];
    3. dropout: each point, with probability ``dropout``, dropped (``keep`` False).

    Args:
        depths: (N,) positive depths, m.
        noise: Standard deviation of the log-normal factor's logarithm, >= 0.
        outliers: Probability that a depth is replaced, in [0, 1].
        dropout: Probability that a point is dropped, in [0, 1].
        low: Smallest outlier depth, m, > 0.
        high: Largest outlier depth, m, > ``low``.
        rng: The episode's generator.

    Returns:
        ``(depths, keep)``: the corrupted (N,) depths (``depths`` itself when noise and outliers are 0) and the
        (N,) mask of the points kept. With all three errors 0 nothing is drawn.

    Raises:
        ValueError: ``low`` or ``high`` cannot bound a log-uniform draw.
    """
    if not 0.0 < low < high:
        raise ValueError(f"outlier depths need 0 < low < high, got low={low!r}, high={high!r}")
    depths = np.asarray(depths, np.float64)
    count = len(depths)
    if noise > 0:
        depths = depths * np.exp(rng.normal(0.0, noise, count))
    if outliers > 0:
        replaced = rng.random(count) < outliers
        depths = depths.copy() if noise <= 0 else depths
        depths[replaced] = np.exp(rng.uniform(math.log(low), math.log(high), int(replaced.sum())))
    keep = rng.random(count) >= dropout if dropout > 0 else np.ones(count, bool)
    return depths, keep


def lagged_attitude(previous: np.ndarray, current: np.ndarray, lag: float) -> np.ndarray:
    """The attitude a clock ``lag`` frames late reports for ``current``: the geodesic interpolation from
    ``previous`` (a frame earlier) toward ``current``, ``lag`` of the way back (0: ``current``; capped at 1:
    ``previous``). Both are world-from-camera rotations (3, 3)."""
    lag = min(max(lag, 0.0), 1.0)
    if lag == 0.0:
        return current
    step = vector_from_rotation(previous.T @ current)
    return previous @ rotation_from_vector((1.0 - lag) * step)
