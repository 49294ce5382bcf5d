"""The sensor specifications the suite's noisy tiers are read from: each number with its source, and how we read it.

The datasheets' numbers are facts; how a number becomes an error setting per camera frame is a reading, stated
beside it. Suite v1 (:func:`realistic_sensor`) and v2 (:func:`flight_stack_sensor`) read the same parts; v2
reads the velocity accuracy once, as the datasheet states it, and makes its error correlated in time, as a
flight stack's velocity estimate is.
"""

from __future__ import annotations

import math

# Bosch Sensortec BMI088 datasheet (BST-BMI088-DS001), gyroscope output noise density: 0.014 °/s/√Hz.
GYRO_NOISE_DENSITY_DEG_S_RTHZ = 0.014
# InvenSense MPU-6000/MPU-6050 product specification (PS-MPU-6000A), gyroscope sensitivity scale factor
# tolerance at 25 °C: ±3 %.
GYRO_SCALE_TOLERANCE = 0.03
# u-blox NEO-M8 data sheet (UBX-15031086), velocity accuracy: 0.05 m/s, a 50 % bound ("50 % @ 30 m/s").
VELOCITY_ACCURACY_M_S = 0.05
# For a normal error per axis, half its draws lie within 0.6745 σ.
MEDIAN_ABS_NORMAL = 0.6745
# The same 50 % bound read three ways, as the per-axis σ (m/s) of a normal error: per axis; on the 3-D speed
# error |v| (a Maxwell distribution, median 1.5382 σ); on the 2-D horizontal one (a Rayleigh distribution,
# median 1.1774 σ). Suite v1 took the largest, per axis.
VELOCITY_READINGS: dict[str, tuple[str, float]] = {
    "per_axis": ("a 50 % bound per axis", VELOCITY_ACCURACY_M_S / MEDIAN_ABS_NORMAL),
    "3d_speed": ("a 50 % bound on the 3-D speed error", VELOCITY_ACCURACY_M_S / 1.5382),
    "2d_speed": ("a 50 % bound on the 2-D speed error", VELOCITY_ACCURACY_M_S / 1.1774),
}
# Suite v2's reading, chosen before any v2 flight: the datasheet gives one accuracy for the velocity, a vector,
# and a probability bound on a vector's error bounds its length; so the 3-D reading. (v1 read it per axis, the
# harshest reading, after a pilot on agents; v2 chooses no reading by an agent's failure.)
FLIGHT_STACK_READING = "3d_speed"
# A GNSS receiver's position and velocity errors are not white: they follow an Ornstein-Uhlenbeck (first-order
# Gauss-Markov) or autoregressive process (Sensors 2020, 20(21), 6050, "Comparison of Enhanced Noise Model
# Performance Based on Analysis of Civilian GPS Data"). The NEO-M8 data sheet's default navigation update rate
# is 1 Hz: a flight stack holds, or propagates with its IMU, one velocity solution for that long, so its error
# persists for about one update interval. Our reading: τ = 1 s. The sensitivity table flies 0.1 s (nearly white,
# as v1) and 10 s (a slowly wandering error) on validation layouts.
VELOCITY_CORRELATION_S = 1.0
VELOCITY_CORRELATION_READINGS_S = (0.1, 1.0, 10.0)
# Camera and IMU clocks that are not hardware-synchronised differ by tens of milliseconds, which is why VIO
# systems estimate the offset online (Li & Mourikis, "Online temporal calibration for camera-IMU systems",
# IJRR 2014; Qin & Shen, "Online temporal calibration for monocular visual-inertial systems", IROS 2018).
# The low end of that order, for a drone whose offset was never calibrated:
CAMERA_IMU_OFFSET_MS = 20.0
# Monocular visual-inertial odometry drifts by about 1 % of the distance flown on the EuRoC MAV sequences
# (Delmerico & Scaramuzza, "A Benchmark Comparison of Monocular Visual-Inertial Odometry Algorithms for
# Flying Robots", ICRA 2018): a scale error of the told translation.
ODOMETRY_SCALE_ERROR = 0.01


def translation_noise_m(velocity_sigma_m_s: float, frame_rate: float = 10.0) -> float:
    """The per-frame translation noise (m, per axis) of a velocity error with σ ``velocity_sigma_m_s``."""
    return round(velocity_sigma_m_s / frame_rate, 6)


def _gyro_settings(frame_rate: float) -> dict[str, float]:
    """The gyro's white rate noise integrated over one frame (N·√Δt) and its scale-factor tolerance."""
    return {
        "rotation_noise_deg": round(GYRO_NOISE_DENSITY_DEG_S_RTHZ * math.sqrt(1.0 / frame_rate), 6),
        "rotation_bias": GYRO_SCALE_TOLERANCE,
    }


def realistic_sensor(frame_rate: float = 10.0) -> dict[str, float]:
    """Suite v1's error settings per camera frame at ``frame_rate`` (Hz):

    - ``rotation_noise_deg``: the gyro's white rate noise integrated over one frame, N·√Δt;
    - ``rotation_bias``: the gyro's scale-factor tolerance, at its worst sign-free value;
    - ``translation_noise_m``: the velocity source's error over one frame, σ_v·Δt per axis, white, read per axis;
    - ``translation_bias``: odometry's scale drift as a share of the distance;
    - ``imu_time_offset_ms``: an uncalibrated camera-IMU clock offset.

    Each but the time offset reuses a setting the sweep already varies (``flownav_env.settings.SensorSettings``).
    """
    return {
        **_gyro_settings(frame_rate),
        "translation_noise_m": translation_noise_m(VELOCITY_READINGS["per_axis"][1], frame_rate),
        "translation_bias": ODOMETRY_SCALE_ERROR,
        "imu_time_offset_ms": CAMERA_IMU_OFFSET_MS,
    }


def flight_stack_sensor(
    frame_rate: float = 10.0,
    reading: str = FLIGHT_STACK_READING,
    correlation_s: float = VELOCITY_CORRELATION_S,
) -> dict[str, float]:
    """Suite v2's error settings: the motion told the way a flight stack tells it. The gyro, odometry scale and
    clock offset as in :func:`realistic_sensor`; the velocity error read as ``reading`` of
    :data:`VELOCITY_READINGS` and correlated in time (a first-order Gauss-Markov process, correlation time
    ``correlation_s``; ``flownav_env.sensor_errors.gauss_markov_step``).

    Raises:
        ValueError: an unknown reading, or a correlation time that is not positive.
    """
    if reading not in VELOCITY_READINGS:
        raise ValueError(f"reading must be one of {', '.join(VELOCITY_READINGS)}, got {reading!r}")
    if not correlation_s > 0:
        raise ValueError(f"correlation_s must be > 0 s, got {correlation_s!r}")
    return {
        **_gyro_settings(frame_rate),
        "translation_noise_m": translation_noise_m(VELOCITY_READINGS[reading][1], frame_rate),
        "translation_noise_correlation_s": correlation_s,
        "translation_bias": ODOMETRY_SCALE_ERROR,
        "imu_time_offset_ms": CAMERA_IMU_OFFSET_MS,
    }
