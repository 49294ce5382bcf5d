"""The benchmark suite's task tiers: a registered Gymnasium id each, frozen under :data:`SUITE_VERSION`.

| tier | id | course | sensor |
|---|---|---|---|
| ``clean`` | ``FlowNav-v0`` | today's defaults: 1 m/s, 0.12 capsules/m² | perfect rotation and translation |
| ``hard`` | ``FlowNavHard-v0`` | :data:`HARD_COURSE` | perfect |
| ``noisy`` | ``FlowNavNoisy-v0`` | defaults | :func:`realistic_sensor`, from datasheets |
| ``hard_noisy`` | ``FlowNavHardNoisy-v0`` | :data:`HARD_COURSE` | :func:`realistic_sensor` |

How each number was chosen is in ``results/suite_calibration/calibration.md``: the hard course on validation
layouts only (``flownav calibrate-tiers``), the sensor from the specifications cited below, read as stated at
each constant. A tier never changes after results are published under its version; any change is a new
:data:`SUITE_VERSION` and new ids.

The realistic sensor is one reading of its specifications, not the only one. Two changes were made after a
pilot on validation layouts showed the first version left no headroom (``sensor_pilot_episodes.csv``): the
velocity accuracy, first read as a standard deviation, became a 50 % bound (σ = 0.074 m/s per axis), and the
uncalibrated camera-IMU clock offset was added. The velocity reading carries most of the tier's difficulty:
read as a 3-D speed error the same bound gives σ = 0.033 m/s per axis, as a 2-D one 0.042 m/s
(:data:`VELOCITY_READINGS`), and at those readings translation noise alone costs a rule little.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from typing import Any

from flownav_env.settings import EnvSettings

# Bump with any change to a tier's settings (and the ids' -vN); every suite result row carries it.
SUITE_VERSION = "1"

# Sensor specifications of parts a small drone flies with (the datasheets' numbers; how each is read is ours,
# stated beside it):
# Bosch Sensortec BMI088 datasheet (BST-BMI088-DS001), gyroscope output noise density: 0.014 °/s/√Hz.
GYRO_NOISE_DENSITY_DEG_S_RTHZ = 0.014
# InvenSense MPU-6000/MPU-6050 product specification (PS-MPU-6000A), gyroscope sensitivity scale factor
# tolerance at 25 °C: ±3 %.
GYRO_SCALE_TOLERANCE = 0.03
# u-blox NEO-M8 data sheet (UBX-15031086), velocity accuracy: 0.05 m/s, a 50 % bound ("50 % @ 30 m/s"). For a
# normal error per axis, half its draws lie within 0.6745 σ, so σ = 0.05 / 0.6745 = 0.074 m/s.
VELOCITY_ACCURACY_M_S = 0.05
MEDIAN_ABS_NORMAL = 0.6745
# The same 50 % bound read three ways, as the per-axis σ (m/s) of a normal error. Suite v1 takes the largest,
# per axis; a 50 % bound on the 3-D speed error |v| (a Maxwell distribution, median 1.5382 σ) or on the 2-D
# horizontal one (a Rayleigh distribution, median 1.1774 σ) gives a milder sensor.
VELOCITY_READINGS: dict[str, tuple[str, float]] = {
    "per_axis": ("a 50 % bound per axis", VELOCITY_ACCURACY_M_S / MEDIAN_ABS_NORMAL),
    "3d_speed": ("a 50 % bound on the 3-D speed error", VELOCITY_ACCURACY_M_S / 1.5382),
    "2d_speed": ("a 50 % bound on the 2-D speed error", VELOCITY_ACCURACY_M_S / 1.1774),
}
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


def realistic_sensor(frame_rate: float = 10.0) -> dict[str, float]:
    """The error settings a drone with the parts above has, per camera frame at ``frame_rate`` (Hz).

    - ``rotation_noise_deg``: the gyro's white rate noise integrated over one frame, N·√Δt;
    - ``rotation_bias``: the gyro's scale-factor tolerance, at its worst sign-free value;
    - ``translation_noise_m``: the velocity source's error over one frame, σ_v·Δt per axis;
    - ``translation_bias``: odometry's scale drift as a share of the distance;
    - ``imu_time_offset_ms``: an uncalibrated camera-IMU clock offset.

    Each but the time offset reuses a setting the sweep already varies (``flownav_env.settings.SensorSettings``).
    """
    frame_time = 1.0 / frame_rate
    return {
        "rotation_noise_deg": round(GYRO_NOISE_DENSITY_DEG_S_RTHZ * math.sqrt(frame_time), 6),
        "rotation_bias": GYRO_SCALE_TOLERANCE,
        "translation_noise_m": translation_noise_m(VELOCITY_ACCURACY_M_S / MEDIAN_ABS_NORMAL, frame_rate),
        "translation_bias": ODOMETRY_SCALE_ERROR,
        "imu_time_offset_ms": CAMERA_IMU_OFFSET_MS,
    }


# Chosen on validation layouts by `flownav calibrate-tiers` (results/suite_calibration/calibration.md): the one whose
# best reactive agent fails closest to the middle of 0.20-0.50.
HARD_COURSE: dict[str, float] = {"forward_speed": 2.0, "obstacle_density": 0.18}


@dataclass(frozen=True)
class Tier:
    """One task of the suite: its registered id and the settings it fixes over the env's defaults."""

    name: str
    env_id: str
    course: Mapping[str, Any] = field(default_factory=dict)
    sensor: Mapping[str, Any] = field(default_factory=dict)
    why: str = ""

    @property
    def settings(self) -> dict[str, Any]:
        """Every setting the tier fixes (course, then sensor)."""
        return {**self.course, **self.sensor}


TIERS: dict[str, Tier] = {
    tier.name: tier
    for tier in (
        Tier("clean", "FlowNav-v0", why="today's defaults, for continuity with the 300-layout history"),
        Tier(
            "hard",
            "FlowNavHard-v0",
            course=HARD_COURSE,
            why="a faster flight through a denser field, where the best existing agent fails 0.20-0.50",
        ),
        Tier(
            "noisy",
            "FlowNavNoisy-v0",
            sensor=realistic_sensor(),
            why="the default course told rotation and translation with a real drone's sensor errors",
        ),
        Tier(
            "hard_noisy",
            "FlowNavHardNoisy-v0",
            course=HARD_COURSE,
            sensor=realistic_sensor(),
            why="the hard course with the realistic sensor",
        ),
    )
}
TIER_NAMES = tuple(TIERS)


def tier(name: str) -> Tier:
    """The tier called ``name``.

    Raises:
        ValueError: not a tier; the message lists them.
    """
    if name not in TIERS:
        raise ValueError(f"tier must be one of {', '.join(TIER_NAMES)}, got {name!r}")
    return TIERS[name]


# The only settings an agent may choose on a tier: each adds an observation key (or shapes one, for
# ``near_smoothing``), so it changes what the agent is shown, never the course it flies or the sensor's errors.
AGENT_OBSERVATION_SETTINGS = (
    "observe_unresolved",
    "observe_counts",
    "observe_nearness",
    "observe_approach",
    "near_smoothing",
)
# Setting values that show an agent what no tier's sensor gives: asked for only by an agent declared privileged
# (true depths; the capsule layout and the drone's true state, flownav_env.privileged).
PRIVILEGED_SETTING_VALUES: dict[str, tuple[Any, ...]] = {
    "obs_source": ("oracle", "oracle_valid"),
    "observe_layout": (True,),
}


def tier_value(tier_name: str, setting: str) -> Any:
    """The value ``tier_name`` flies ``setting`` with: the tier's own, else the env's default (a tier fixes
    every setting an agent may not choose).

    Raises:
        ValueError: an unknown tier or setting.
    """
    spec = tier(tier_name)
    defaults = {item.name: item.default for item in fields(EnvSettings)}
    if setting not in defaults:
        raise ValueError(f"{setting!r} is not a FlowNav env setting")
    return spec.settings.get(setting, defaults[setting])


def privileged_requests(wanted: Mapping[str, Any]) -> dict[str, Any]:
    """The entries of ``wanted`` (env settings an agent asks for) that would show it privileged data."""
    return {
        key: value
        for key, value in wanted.items()
        if key in PRIVILEGED_SETTING_VALUES and value in PRIVILEGED_SETTING_VALUES[key]
    }


def check_agent_settings(
    agent: str, wanted: Mapping[str, Any], tier_name: str, *, privileged: bool = False
) -> None:
    """Refuse an agent that asks ``tier_name`` for anything but observation keys, so every agent on a tier flies
    the same task. Asking for a setting's tier value is no change and passes; privileged data (true depths)
    passes only for an agent declared ``privileged``.

    Raises:
        ValueError: one line naming the agent, the setting, the value asked for and the tier's value.
    """
    for key, value in wanted.items():
        if key in AGENT_OBSERVATION_SETTINGS:
            continue
        fixed = tier_value(tier_name, key)
        if key in privileged_requests({key: value}):
            if privileged:
                continue
            raise ValueError(
                f"agent {agent} asks for {key}={value!r}, privileged data the tier {tier_name} sensor does not "
                "give; only an agent declared privileged (privileged = True) may, and it is listed as a "
                "reference, never ranked"
            )
        if value != fixed:
            raise ValueError(
                f"agent {agent} asks for {key}={value!r}, but tier {tier_name} fixes {key}={fixed!r}: an agent "
                f"may choose only {', '.join(AGENT_OBSERVATION_SETTINGS)}"
            )


def check_flown_settings(
    agent: str, flown: Mapping[str, Any], tier_name: str, *, privileged: bool = False
) -> None:
    """Refuse episodes of ``agent`` recorded on ``tier_name`` with settings ``flown`` (the env kwargs its
    episode records hold) that are not the tier's task: a tier setting missing or changed, or anything else
    that :func:`check_agent_settings` refuses.

    Raises:
        ValueError: one line naming the agent, the tier and the first setting that differs.
    """
    for key, value in tier(tier_name).settings.items():
        if key not in flown or flown[key] != value:
            raise ValueError(
                f"agent {agent} was flown on tier {tier_name} with {key}={flown.get(key, 'the default')!r}, but "
                f"the tier fixes {key}={value!r}: these are not the tier's episodes"
            )
    others = {key: value for key, value in flown.items() if key not in tier(tier_name).settings}
    check_agent_settings(agent, others, tier_name, privileged=privileged)
