"""The one declaration of every FlowNav env and sensor setting: its default, its allowed values and its meaning.

Each :class:`EnvSettings` field carries its rule (:class:`Range`, :class:`Choice`, ..., from
:mod:`flownav_env.setting_rules`) and a one-line meaning in its dataclass metadata; ``__post_init__`` checks
every field against its rule, so a range is written here once and read by the env (whose constructor takes
these fields as keywords, and whose Arguments table is made from them: :mod:`flownav_env.env_arguments`), the
playback, sweeps, training randomisation and the YAML configs (:mod:`flownav_env.settings_check`). Error
messages name the parameter, the value received and the allowed values.

The sensor settings (:class:`SensorSettings`, changeable per episode through ``FlowNavEnv.set_sensor``) model
what the drone senses wrongly; :mod:`flownav_env.sensor_errors` defines each model and holds its maths, and
:class:`flownav_env.sensor.SensorPipeline` applies them in the per-frame order.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from functools import cached_property
from typing import Any, cast

from estimator import DEFAULT_BIN_EDGES, CameraIntrinsics
from flownav_env.scene import LAYOUTS, LayoutParams
from flownav_env.setting_rules import (
    AnyInteger,
    BinEdges,
    Choice,
    EstimatorArguments,
    Flag,
    Range,
    Sectors,
    check_fields,
)
from flownav_env.setting_rules import setting_field as _setting

OBS_SOURCES = ("flow", "oracle", "oracle_valid")
# The estimator's own FAST threshold (20) was chosen on 640×480 frames. The env's 160×120 frames hold a
# sixteenth of the pixels, and at 20 only about a third of the tracked points get a depth: too sparse a
# histogram to steer by. See results/env_performance.md ("Default resolution and FAST threshold").
ENV_ESTIMATOR_DEFAULTS: dict[str, Any] = {"fast_threshold": 10}
# A biased scale factor 1 + b stays inside [0.1, 1.9]: the bias settings' range and the drifting bias's.
BIAS_LIMIT = 0.9
_BIAS = Range(-BIAS_LIMIT, BIAS_LIMIT)
_DRIFT = Range(0.0, 1.0, unit="1/√s")
_FRACTION = Range(0.0, 1.0)
_SPEED = Range(0.0, 5.0, low_open=True, unit="m/s")
_WEIGHT = Range(0.0, math.inf, high_open=True)
_PIXELS = Range(16, 1280, integer=True, unit="px")
_OBSERVE = "add the observation key "


@dataclass(frozen=True)
class SensorSettings:
    """The sensor variables training may change between episodes (see :meth:`FlowNavEnv.set_sensor`)."""

    attitude_jitter_deg: float = _setting(
        0.0,
        Range(0.0, 10.0, unit="deg"),
        "camera attitude disturbance per frame, uniform ± per axis: real, and known to the system",
    )
    brightness: float = _setting(1.0, Range(0.0, 4.0), "scene light level, 1 = daylight")
    rotation_error: float = _setting(
        0.0,
        Range(0.0, 1.0),
        "per-frame relative error of the rotation told to the estimator: each axis-angle component times a "
        "factor uniform in 1 ± this",
    )
    translation_error: float = _setting(
        0.0,
        Range(0.0, 1.0),
        "per-frame relative error of the translation told to the estimator: each component times a factor "
        "uniform in 1 ± this",
    )
    rotation_bias: float = _setting(
        0.0,
        _BIAS,
        "constant scale error of the told rotation (a mis-calibrated gyro): every frame's told rotation angle "
        "times 1 + this, its axis unchanged",
    )
    translation_bias: float = _setting(
        0.0,
        _BIAS,
        "constant scale error of the told translation (mis-calibrated odometry): every frame's told "
        "translation times 1 + this",
    )
    rotation_drift: float = _setting(
        0.0,
        _DRIFT,
        "random walk of the rotation bias: from ``rotation_bias`` at reset it changes by N(0, drift² · Δt) per "
        "frame (Δt = 1/``frame_rate``), so this is its standard deviation after 1 s; the applied bias is "
        "clipped to ±0.9",
    )
    translation_drift: float = _setting(
        0.0, _DRIFT, "random walk of the translation bias, as ``rotation_drift`` from ``translation_bias``"
    )
    rotation_noise_deg: float = _setting(
        0.0,
        Range(0.0, 10.0, unit="deg"),
        "absolute noise floor of the told rotation: a rotation of N(0, this²) per axis composed onto it every "
        "frame, turning or not",
    )
    translation_noise_m: float = _setting(
        0.0,
        Range(0.0, 0.5, unit="m"),
        "absolute noise floor of the told translation: N(0, this²) per axis added every frame",
    )
    translation_noise_correlation_s: float = _setting(
        0.0,
        Range(0.0, 600.0, unit="s"),
        "correlation time of ``translation_noise_m``: 0 draws it afresh every frame (white noise); τ > 0 makes it "
        "a velocity estimate's error, a first-order Gauss-Markov process in the world's axes with stationary "
        "σ ``translation_noise_m`` per frame and correlation exp(−Δt/τ) from one frame to the next",
    )
    imu_time_offset_ms: float = _setting(
        0.0,
        Range(0.0, 100.0, unit="ms"),
        "camera-IMU time offset: the attitude the estimator is told for a frame is the camera's this long "
        "before it, interpolated between frames (capped at one frame interval), so a change of turn rate "
        "becomes a rotation error",
    )
    depth_noise: float = _setting(
        0.0,
        Range(0.0, 2.0),
        "σ of log-normal noise on the estimated depths: depth · exp(N(0, σ²)); flow observations only, as the "
        "two below",
    )
    depth_outliers: float = _setting(
        0.0,
        _FRACTION,
        "share of the estimated depths replaced by depths drawn log-uniformly over the histogram's range: from "
        "the first bin edge (half the second if the first is 0) to the last",
    )
    depth_dropout: float = _setting(
        0.0,
        _FRACTION,
        "share of the estimated depths removed: those points are gone, from the histogram, ``unresolved`` and "
        "``info`` alike; ``info`` measures the depths the agent sees",
    )

    def __post_init__(self) -> None:
        check_fields(self)

    @property
    def depth_errors(self) -> bool:
        """Whether any depth error is on (else the estimated depths go to the histogram untouched)."""
        return any(getattr(self, name) > 0 for name in DEPTH_ERROR_FIELDS)


SENSOR_FIELDS = tuple(item.name for item in fields(SensorSettings))
# What training may vary between episodes besides the sensor (FlowNavEnv.set_course; from the next reset).
COURSE_FIELDS = ("forward_speed", "obstacle_density")
DEPTH_ERROR_FIELDS = ("depth_noise", "depth_outliers", "depth_dropout")


@dataclass(frozen=True)
class EnvSettings(SensorSettings):
    """Every :class:`flownav_env.FlowNavEnv` setting: what shapes the world, the flight, the sensor, the
    observation and the reward, checked on construction (fields are checked in this order, so a range tied to
    another setting comes after it: the sensor fields, inherited from :class:`SensorSettings`, come first and
    depend on nothing).

    Raises:
        ValueError: A value is outside its rule; the message names the setting, the value and the rule.
    """

    layout: str = _setting(
        "field",
        Choice(LAYOUTS),
        "obstacle course: a random field, a bending corridor, one capsule ahead (thesis Fig. 14) or three "
        "(Fig. 41)",
    )
    obs_source: str = _setting(
        "flow",
        Choice(OBS_SOURCES),
        "depths observed: the estimator's, the true depth at the tracked points, or the true depth at the "
        "points with a valid estimate",
    )
    observe_unresolved: bool = _setting(
        False,
        Flag(),
        _OBSERVE + "``unresolved``: where the estimator tracks points it cannot range (a histogram counts "
        "only ranged points, so it cannot tell a lone near point in open space from a wall)",
    )
    observe_counts: bool = _setting(
        False, Flag(), _OBSERVE + "``point_counts``: how much each sector's histogram rests on"
    )
    observe_nearness: bool = _setting(
        False,
        Flag(),
        _OBSERVE
        + "``nearness``: how near each sector's nearest surface is (a histogram spreads it over bins)",
    )
    observe_approach: bool = _setting(
        False,
        Flag(),
        _OBSERVE
        + "``approach``: how soon the drone reaches each sector's nearest surface at its forward speed",
    )
    observe_layout: bool = _setting(
        False,
        Flag(),
        "add the observation keys ``layout``, ``layout_mask``, ``true_state``, ``course``, ``camera`` and "
        "``depth_bin_edges``: the capsules, the drone's true state, the course's limits and the camera's true pose "
        "and view, which no sensor gives (privileged: reference agents only)",
    )
    near_smoothing: float = _setting(
        1.0,
        Range(0.0, 1.0, low_open=True),
        "weight of the newest frame in ``nearness`` and ``approach``'s exponential average over the episode's "
        "frames; 1 = this frame only",
    )
    depth_error_info: bool = _setting(
        True,
        Flag(),
        'ray-cast the true depth of the tracked points each step for ``info["depth_error_median"]`` and '
        '``info["depth_outlier_share"]`` (off by > 50 %); False skips it (about 0.3 ms per step) where only '
        "flow observations are used, as in training",
    )
    obstacle_radius: float = _setting(0.5, Range(0.0, 2.0, low_open=True, unit="m"), "capsule radius")
    obstacle_height: float = _setting(
        2.0,
        Range(None, 10.0, low_open=True, unit="m", low_from="obstacle_radius", low_scale=2.0),
        "capsule height",
    )
    obstacle_density: float = _setting(
        0.12, Range(0.0, 1.0, unit="1/m²"), "field capsules per m² of the obstacle band"
    )
    field_length: float = _setting(
        20.0, Range(5.0, 200.0, unit="m"), "start to goal line for field and corridor"
    )
    field_width: float = _setting(
        8.0, Range(1.0, 100.0, unit="m"), "width of the band holding field capsules"
    )
    corridor_width: float = _setting(
        2.5, Range(0.0, 20.0, low_open=True, unit="m"), "free width of a corridor"
    )
    corridor_bend: float = _setting(
        1.5, Range(0.0, 10.0, unit="m"), "largest sideways excursion of a corridor"
    )
    forward_speed: float = _setting(1.0, Range(0.0, 5.0, unit="m/s"), "forward speed; 0 hovers")
    frame_rate: float = _setting(10.0, Range(1.0, 50.0, unit="Hz"), "camera frames = agent steps per second")
    flight_height: float = _setting(1.0, Range(0.3, 5.0, unit="m"), "starting height")
    max_height: float = _setting(
        1.8,
        Range(None, 20.0, low_open=True, unit="m", low_from="flight_height"),
        "out of bounds above this height",
    )
    lateral_bound: float = _setting(
        6.0,
        Range(0.0, 100.0, low_open=True, unit="m"),
        "out of bounds beyond this sideways distance from the course axis",
    )
    camera_width: int = _setting(160, _PIXELS, "camera image width")
    camera_height: int = _setting(120, _PIXELS, "camera image height")
    camera_fov_deg: float = _setting(60.0, Range(10.0, 150.0, unit="deg"), "vertical field of view")
    histogram_sectors: tuple[int, int] = _setting(
        (3, 5),
        Sectors(Range(1, 32, integer=True)),
        "image sector rows and columns of the observation; like ``depth_bin_edges``, an agent may ask any tier for "
        "another resolution (the same depths binned otherwise; ``flownav_env.tiers.AGENT_OBSERVATION_SETTINGS``)",
    )
    depth_bin_edges: tuple[float, ...] = _setting(
        tuple(DEFAULT_BIN_EDGES),
        BinEdges(),
        "depth bin edges of the histogram (m; beyond the last edge counts in the last bin); like "
        "``histogram_sectors``, an agent may ask any tier for other bins",
    )
    max_lateral_speed: float = _setting(1.0, _SPEED, "lateral speed at action 1")
    max_vertical_speed: float = _setting(0.5, _SPEED, "vertical speed at action 1")
    max_yaw_rate_deg: float = _setting(
        45.0, Range(0.0, 360.0, low_open=True, unit="deg/s"), "yaw rate at action 1"
    )
    progress_weight: float = _setting(1.0, _WEIGHT, "reward per metre of progress toward the goal line")
    success_bonus: float = _setting(10.0, _WEIGHT, "reward on reaching the goal")
    collision_penalty: float = _setting(10.0, _WEIGHT, "penalty on a collision or on leaving the bounds")
    control_cost_weight: float = _setting(0.05, _WEIGHT, "weight of ‖action‖²")
    clearance_weight: float = _setting(
        0.0,
        _WEIGHT,
        "the most a step closer than ``safe_clearance`` to a capsule can cost; 0 turns clearance shaping off",
    )
    safe_clearance: float = _setting(
        0.5,
        Range(0.0, 5.0, low_open=True, unit="m"),
        "clearance below which the clearance penalty starts",
    )
    # Physics at 200 Hz or faster keeps the inner attitude loop stable.
    physics_timestep: float = _setting(
        0.004, Range(0.0005, 0.005, unit="s"), "MuJoCo timestep (physics ≥ 200 Hz)"
    )
    texture_seed: int = _setting(0, AnyInteger(), "seed of the procedural textures (the world's look)")
    estimator_kwargs: Mapping[str, Any] = _setting(
        None,
        EstimatorArguments(),
        "the depth estimator's settings (method, thresholds, ...), over ``ENV_ESTIMATOR_DEFAULTS`` "
        "(``fast_threshold=10``)",
    )

    def __post_init__(self) -> None:
        check_fields(self)

    @cached_property
    def sensor(self) -> SensorSettings:
        """The sensor variables of these settings."""
        return SensorSettings(**{name: getattr(self, name) for name in SENSOR_FIELDS})

    def with_sensor(self, **values: float) -> EnvSettings:
        """These settings with some sensor variables changed (and checked).

        Raises:
            ValueError: A name is not a sensor variable, or a value is outside its range.
        """
        return self._with_some(SENSOR_FIELDS, "sensor settings", values)

    def with_course(self, **values: float) -> EnvSettings:
        """These settings with the course's speed or obstacle density changed (and checked).

        Raises:
            ValueError: A name is not one of :data:`COURSE_FIELDS`, or a value is outside its range.
        """
        return self._with_some(COURSE_FIELDS, "course settings", values)

    def _with_some(self, allowed: tuple[str, ...], kind: str, values: Mapping[str, float]) -> EnvSettings:
        unknown = sorted(set(values) - set(allowed))
        if unknown:
            raise ValueError(f"not {kind}: {unknown}; allowed: {', '.join(allowed)}")
        # Any value may come in: the new settings check each against its rule as they are built.
        return replace(self, **cast("dict[str, Any]", values))

    def layout_params(self) -> LayoutParams:
        """The obstacle-course geometry these settings describe."""
        return LayoutParams(
            obstacle_radius=self.obstacle_radius,
            obstacle_height=self.obstacle_height,
            obstacle_density=self.obstacle_density,
            field_length=self.field_length,
            field_width=self.field_width,
            corridor_width=self.corridor_width,
            corridor_bend=self.corridor_bend,
        )

    def intrinsics(self) -> CameraIntrinsics:
        """The forward camera's pinhole model."""
        return CameraIntrinsics.from_fov(self.camera_width, self.camera_height, self.camera_fov_deg)

    def estimator_arguments(self) -> dict[str, Any]:
        """FlowDepthEstimator keyword arguments: the caller's over :data:`ENV_ESTIMATOR_DEFAULTS`."""
        return {**ENV_ESTIMATOR_DEFAULTS, **self.estimator_kwargs}

    @property
    def substeps(self) -> int:
        """Physics steps per camera frame."""
        return max(1, round(1.0 / (self.frame_rate * self.physics_timestep)))

    @property
    def max_yaw_rate(self) -> float:
        """Yaw rate at action 1, rad/s."""
        return math.radians(self.max_yaw_rate_deg)

    @property
    def needs_true_depth(self) -> bool:
        """Whether a step ray-casts the true depth of the tracked points (for an oracle or for ``info``)."""
        return self.depth_error_info or self.obs_source != "flow"


SETTING_NAMES = tuple(item.name for item in fields(EnvSettings))
