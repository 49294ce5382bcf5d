"""The one owner of every FlowNav env and sensor parameter, its default and its allowed range.

Each :class:`EnvSettings` field carries its rule (:class:`Range`, :class:`Choice`, ..., from
:mod:`flownav_env.rules`) in its dataclass metadata, and ``__post_init__`` checks every field against it, so a
range is written here once and read by the env, the playback, sweeps and training randomisation through
:func:`check_setting` and :func:`setting_range`. Error messages name the parameter, the value received and
the allowed values.

The sensor settings (:data:`SENSOR_RULES`, changeable per episode through ``FlowNavEnv.set_sensor``) model
what the drone senses wrongly. Their ``meaning`` strings are the rows of FlowNavEnv's Arguments table
(:func:`sensor_argument_rows`); :mod:`flownav_env.errors` holds the maths and
:class:`flownav_env.sensor.SensorPipeline` the per-frame order. Four kinds of error:

* **Per-frame relative error** (the thesis's): ``rotation_error``, ``translation_error``.
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
* **Depth errors**, independent of their cause, on the estimator's valid depths before the histogram (flow
  observations only; the oracles' true depths are left alone): log-normal noise ``depth · exp(N(0,
  depth_noise²))``, then a fraction ``depth_outliers`` replaced by depths drawn log-uniformly over the
  histogram's range (:func:`flownav_env.errors.outlier_depth_range`), then a fraction ``depth_dropout``
  removed: those points are simply gone (from the histogram, the ``unresolved`` share and ``info``), not
  counted as tracked points without a depth. ``info["points_tracked"]``, ``["points_valid"]`` and
  ``["depth_error_median"]`` then describe the corrupted depths, what the agent sees, so that a sweep's
  depth error says how wrong the observation was (with the errors at 0 they are the estimator's own).

Every error draws from the episode's generator only when its setting is non-zero, so at the defaults no
draw and no arithmetic is added and an episode is the same as before these settings existed.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from functools import cached_property
from typing import Any

from estimator import DEFAULT_BIN_EDGES, CameraIntrinsics
from flownav_env.rules import (
    AnyInteger,
    BinEdges,
    Choice,
    EstimatorArguments,
    Flag,
    Range,
    Rule,
    Sectors,
    check_fields,
)
from flownav_env.rules import setting_field as _setting
from flownav_env.scene import LAYOUTS, LayoutParams

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


# The sensor's test variables: SensorSettings and EnvSettings both take their rules from here.
# Their meanings are the rows of FlowNavEnv's Arguments table (see the module docstring for the full models).
SENSOR_RULES: dict[str, Range] = {
    "attitude_jitter_deg": Range(
        0.0,
        10.0,
        unit="deg",
        meaning="camera attitude disturbance per frame, uniform ± per axis: real, and known to the system",
    ),
    "brightness": Range(0.0, 4.0, meaning="scene light level, 1 = daylight"),
    "rotation_error": Range(
        0.0,
        1.0,
        meaning="per-frame relative error of the rotation told to the estimator: each axis-angle component "
        "times a factor uniform in 1 ± this",
    ),
    "translation_error": Range(
        0.0,
        1.0,
        meaning="per-frame relative error of the translation told to the estimator: each component times a "
        "factor uniform in 1 ± this",
    ),
    "rotation_bias": replace(
        _BIAS,
        meaning="constant scale error of the told rotation (a mis-calibrated gyro): every frame's told "
        "rotation angle times 1 + this, its axis unchanged",
    ),
    "translation_bias": replace(
        _BIAS,
        meaning="constant scale error of the told translation (mis-calibrated odometry): every frame's told "
        "translation times 1 + this",
    ),
    "rotation_drift": replace(
        _DRIFT,
        meaning="random walk of the rotation bias: from ``rotation_bias`` at reset it changes by N(0, "
        "drift² · Δt) per frame (Δt = 1/``frame_rate``), so this is its standard deviation after 1 s; the "
        "applied bias is clipped to ±0.9",
    ),
    "translation_drift": replace(
        _DRIFT,
        meaning="random walk of the translation bias, as ``rotation_drift`` from ``translation_bias``",
    ),
    "rotation_noise_deg": Range(
        0.0,
        10.0,
        unit="deg",
        meaning="absolute noise floor of the told rotation: a rotation of N(0, this²) per axis composed "
        "onto it every frame, turning or not",
    ),
    "translation_noise_m": Range(
        0.0,
        0.5,
        unit="m",
        meaning="absolute noise floor of the told translation: N(0, this²) per axis added every frame",
    ),
    "depth_noise": Range(
        0.0,
        2.0,
        meaning="σ of log-normal noise on the estimated depths: depth · exp(N(0, σ²)); flow observations "
        "only, as the two below",
    ),
    "depth_outliers": replace(
        _FRACTION,
        meaning="share of the estimated depths replaced by depths drawn log-uniformly over the histogram's "
        "range: from the first bin edge (half the second if the first is 0) to the last",
    ),
    "depth_dropout": replace(
        _FRACTION,
        meaning="share of the estimated depths removed: those points are gone, from the histogram, "
        "``unresolved`` and ``info`` alike; ``info`` measures the depths the agent sees",
    ),
}
SENSOR_FIELDS = tuple(SENSOR_RULES)
# What training may vary between episodes besides the sensor (FlowNavEnv.set_course; from the next reset).
COURSE_FIELDS = ("forward_speed", "obstacle_density")
DEPTH_ERROR_FIELDS = ("depth_noise", "depth_outliers", "depth_dropout")
_SPEED = Range(0.0, 5.0, low_open=True, unit="m/s", meaning="speed at action 1")
_WEIGHT = Range(0.0, math.inf, high_open=True, meaning="reward weight")
_PIXELS = Range(16, 1280, integer=True, unit="px", meaning="camera resolution")


@dataclass(frozen=True)
class SensorSettings:
    """The sensor variables training may change between episodes (see :meth:`FlowNavEnv.set_sensor`)."""

    attitude_jitter_deg: float = _setting(0.0, SENSOR_RULES["attitude_jitter_deg"])
    brightness: float = _setting(1.0, SENSOR_RULES["brightness"])
    rotation_error: float = _setting(0.0, SENSOR_RULES["rotation_error"])
    translation_error: float = _setting(0.0, SENSOR_RULES["translation_error"])
    rotation_bias: float = _setting(0.0, SENSOR_RULES["rotation_bias"])
    translation_bias: float = _setting(0.0, SENSOR_RULES["translation_bias"])
    rotation_drift: float = _setting(0.0, SENSOR_RULES["rotation_drift"])
    translation_drift: float = _setting(0.0, SENSOR_RULES["translation_drift"])
    rotation_noise_deg: float = _setting(0.0, SENSOR_RULES["rotation_noise_deg"])
    translation_noise_m: float = _setting(0.0, SENSOR_RULES["translation_noise_m"])
    depth_noise: float = _setting(0.0, SENSOR_RULES["depth_noise"])
    depth_outliers: float = _setting(0.0, SENSOR_RULES["depth_outliers"])
    depth_dropout: float = _setting(0.0, SENSOR_RULES["depth_dropout"])

    def __post_init__(self) -> None:
        check_fields(self)

    @property
    def depth_errors(self) -> bool:
        """Whether any depth error is on (else the estimated depths go to the histogram untouched)."""
        return any(getattr(self, name) > 0 for name in DEPTH_ERROR_FIELDS)


@dataclass(frozen=True)
class EnvSettings(SensorSettings):
    """Every :class:`flownav_env.FlowNavEnv` constructor argument that shapes the world, the flight or the
    sensor, checked on construction (fields are checked in this order, so a range tied to another setting
    comes after it: the sensor fields, inherited from :class:`SensorSettings`, come first and depend on
    nothing). Each rule carries a one-line meaning; FlowNavEnv's Arguments table explains them.

    Raises:
        ValueError: A value is outside its rule; the message names the setting, the value and the rule.
    """

    layout: str = _setting("field", Choice(LAYOUTS))
    obs_source: str = _setting("flow", Choice(OBS_SOURCES))
    observe_unresolved: bool = _setting(False, Flag())
    observe_counts: bool = _setting(False, Flag())
    observe_nearness: bool = _setting(False, Flag())
    observe_approach: bool = _setting(False, Flag())
    near_smoothing: float = _setting(1.0, Range(0.0, 1.0, low_open=True, meaning="newest frame's weight"))
    depth_error_info: bool = _setting(True, Flag())
    obstacle_radius: float = _setting(0.5, Range(0.0, 2.0, low_open=True, unit="m", meaning="capsule radius"))
    obstacle_height: float = _setting(
        2.0,
        Range(
            None,
            10.0,
            low_open=True,
            unit="m",
            meaning="capsule height",
            low_from="obstacle_radius",
            low_scale=2.0,
        ),
    )
    obstacle_density: float = _setting(
        0.12, Range(0.0, 1.0, unit="1/m²", meaning="field capsules per m² of the obstacle band")
    )
    field_length: float = _setting(20.0, Range(5.0, 200.0, unit="m", meaning="start to goal line"))
    field_width: float = _setting(
        8.0, Range(1.0, 100.0, unit="m", meaning="width of the band of field capsules")
    )
    corridor_width: float = _setting(
        2.5, Range(0.0, 20.0, low_open=True, unit="m", meaning="free width of a corridor")
    )
    corridor_bend: float = _setting(
        1.5, Range(0.0, 10.0, unit="m", meaning="largest sideways excursion of a corridor")
    )
    forward_speed: float = _setting(1.0, Range(0.0, 5.0, unit="m/s", meaning="forward speed; 0 hovers"))
    frame_rate: float = _setting(
        10.0, Range(1.0, 50.0, unit="Hz", meaning="camera frames = agent steps per second")
    )
    flight_height: float = _setting(1.0, Range(0.3, 5.0, unit="m", meaning="starting height"))
    max_height: float = _setting(
        1.8,
        Range(None, 20.0, low_open=True, unit="m", meaning="out of bounds above", low_from="flight_height"),
    )
    lateral_bound: float = _setting(
        6.0, Range(0.0, 100.0, low_open=True, unit="m", meaning="out of bounds sideways beyond")
    )
    camera_width: int = _setting(160, _PIXELS)
    camera_height: int = _setting(120, _PIXELS)
    camera_fov_deg: float = _setting(60.0, Range(10.0, 150.0, unit="deg", meaning="vertical field of view"))
    histogram_sectors: tuple[int, int] = _setting(
        (3, 5), Sectors(Range(1, 32, integer=True, meaning="sector rows or columns"))
    )
    depth_bin_edges: tuple[float, ...] = _setting(tuple(DEFAULT_BIN_EDGES), BinEdges())
    max_lateral_speed: float = _setting(1.0, _SPEED)
    max_vertical_speed: float = _setting(0.5, _SPEED)
    max_yaw_rate_deg: float = _setting(
        45.0, Range(0.0, 360.0, low_open=True, unit="deg/s", meaning="yaw rate at action 1")
    )
    progress_weight: float = _setting(1.0, _WEIGHT)
    success_bonus: float = _setting(10.0, _WEIGHT)
    collision_penalty: float = _setting(10.0, _WEIGHT)
    control_cost_weight: float = _setting(0.05, _WEIGHT)
    clearance_weight: float = _setting(0.0, _WEIGHT)
    safe_clearance: float = _setting(
        0.5,
        Range(
            0.0, 5.0, low_open=True, unit="m", meaning="clearance below which the clearance penalty starts"
        ),
    )
    # Physics at 200 Hz or faster keeps the inner attitude loop stable.
    physics_timestep: float = _setting(0.004, Range(0.0005, 0.005, unit="s", meaning="MuJoCo timestep"))
    texture_seed: int = _setting(0, AnyInteger())
    estimator_kwargs: Mapping[str, Any] = _setting(None, EstimatorArguments())

    def __post_init__(self) -> None:
        check_fields(self)

    @cached_property
    def sensor(self) -> SensorSettings:
        """The sensor variables of these settings."""
        return SensorSettings(**{name: getattr(self, name) for name in SENSOR_FIELDS})

    def with_sensor(self, **values: Any) -> EnvSettings:
        """These settings with some sensor variables changed (and checked).

        Raises:
            ValueError: A name is not a sensor variable, or a value is outside its range.
        """
        return self._with_some(SENSOR_FIELDS, "sensor settings", values)

    def with_course(self, **values: Any) -> EnvSettings:
        """These settings with the course's speed or obstacle density changed (and checked).

        Raises:
            ValueError: A name is not one of :data:`COURSE_FIELDS`, or a value is outside its range.
        """
        return self._with_some(COURSE_FIELDS, "course settings", values)

    def _with_some(self, allowed: tuple[str, ...], kind: str, values: dict[str, Any]) -> EnvSettings:
        unknown = sorted(set(values) - set(allowed))
        if unknown:
            raise ValueError(f"not {kind}: {unknown}; allowed: {', '.join(allowed)}")
        return replace(self, **values)

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


def settings_property(name: str, sensor: bool = False) -> property:
    """An env attribute that reads ``env.settings.<name>``, so the settings stay its one owner; a sensor
    variable's attribute can be assigned, which goes through ``env.set_sensor`` (checked, applied)."""
    setter = (lambda env, value: env.set_sensor(**{name: value})) if sensor else None
    return property(lambda env: getattr(env.settings, name), setter, doc=f"``settings.{name}``")


def with_sensor_settings(env_class: type) -> type:
    """Class decorator for FlowNavEnv: each sensor setting becomes an attribute that reads the settings and
    assigns through ``set_sensor``, and the docstring's ``{sensor_rows}`` marker becomes the sensor rows of
    its Arguments table (:func:`sensor_argument_rows`)."""
    for name in SENSOR_FIELDS:
        setattr(env_class, name, settings_property(name, sensor=True))
    if env_class.__doc__:  # None under python -OO
        env_class.__doc__ = env_class.__doc__.replace("{sensor_rows}", sensor_argument_rows())
    return env_class


def _rule(name: str) -> Rule:
    rules = {item.name: item.metadata["rule"] for item in fields(EnvSettings)}
    if name not in rules:
        raise ValueError(f"unknown setting {name!r}; known: {', '.join(rules)}")
    return rules[name]


def setting_range(name: str, **others: float) -> Range:
    """The numeric range of setting ``name``, so callers can read its low and high ends.

    A range tied to another setting (``max_height`` above ``flight_height``, ``obstacle_height`` above twice
    ``obstacle_radius``) is resolved against that setting's value in ``others``, else its default.

    Raises:
        ValueError: ``name`` is not a setting, or not a numeric one.
    """
    rule = _rule(name)
    if not isinstance(rule, Range):
        raise ValueError(f"{name} is not a numeric setting (its rule is {type(rule).__name__})")
    if rule.low_from is not None:
        default = next(item.default for item in fields(EnvSettings) if item.name == rule.low_from)
        rule = rule.resolved(others.get(rule.low_from, default))
    return rule


def check_setting(name: str, value: Any, **others: float) -> Any:
    """``value`` checked against setting ``name``'s rule and normalised (float, int, tuple, ...).

    For sweeps, training randomisation, playback and experiment configs that take one setting on its own;
    ``others`` resolves ranges tied to another setting as in :func:`setting_range`.

    Raises:
        ValueError: ``name`` is unknown, or ``value`` breaks its rule (the message names both and the rule).
    """
    rule = _rule(name)
    if isinstance(rule, Range):
        rule = setting_range(name, **others)
    return rule.check(name, value)


def sensor_argument_rows(indent: str = "    ") -> str:
    """FlowNavEnv's Arguments table rows of the sensor settings, from their rules' meanings (one owner).

    Each row reads ``| ``name`` | default | meaning; in [low, high] unit |``; rows after the first start
    with ``indent``, so the result can replace a marker indented like the table.
    """
    defaults = {item.name: item.default for item in fields(SensorSettings)}
    rows = []
    for name, rule in SENSOR_RULES.items():
        opened, closed = "(" if rule.low_open else "[", ")" if rule.high_open else "]"
        unit = f" {rule.unit}" if rule.unit else ""
        interval = f"{opened}{rule.low:g}, {rule.high:g}{closed}{unit}"
        rows.append(f"| ``{name}`` | {defaults[name]:g} | {rule.meaning}; in {interval} |")
    return f"\n{indent}".join(rows)
