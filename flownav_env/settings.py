"""The one owner of every FlowNav env and sensor parameter, its default and its allowed range.

Each :class:`EnvSettings` field carries its rule (:class:`Range`, :class:`Choice`, ...) in its dataclass
metadata, and ``__post_init__`` checks every field against it, so a range is written here once and read by
the env, the playback, sweeps and training randomisation through :func:`check_setting` and
:func:`setting_range`. Error messages name the parameter, the value received and the allowed values.
"""

from __future__ import annotations

import inspect
import math
import types
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from functools import cached_property
from typing import Any, Protocol

import numpy as np

from estimator import DEFAULT_BIN_EDGES, CameraIntrinsics, FlowDepthEstimator
from flownav_env.scene import LAYOUTS, LayoutParams

OBS_SOURCES = ("flow", "oracle", "oracle_valid")
SENSOR_FIELDS = ("attitude_jitter_deg", "brightness", "rotation_error", "translation_error")
# The estimator's own FAST threshold (20) was chosen on 640×480 frames. The env's 160×120 frames hold a
# sixteenth of the pixels, and at 20 only about a third of the tracked points get a depth: too sparse a
# histogram to steer by. See results/env_performance.md ("Default resolution and FAST threshold").
ENV_ESTIMATOR_DEFAULTS: dict[str, Any] = {"fast_threshold": 10}


class Rule(Protocol):
    """What a setting's metadata holds: a check that returns the value in its stored form."""

    def check(self, name: str, value: Any) -> Any: ...


@dataclass(frozen=True)
class Range:
    """A numeric interval, the one validator for numbers in :mod:`flownav_env`.

    ``low`` may instead come from another setting (``low_from``, times ``low_scale``), for the rules that tie
    two settings (``max_height`` above ``flight_height``); :meth:`resolved` fills it in.
    """

    low: float | None
    high: float
    low_open: bool = False
    high_open: bool = False
    integer: bool = False
    unit: str = ""
    meaning: str = ""
    low_from: str | None = None
    low_scale: float = 1.0

    @property
    def interval(self) -> str:
        """The interval as the error messages and the docs write it, e.g. ``(0.0, 5.0]``."""
        return f"{'(' if self.low_open else '['}{self.low}, {self.high}{')' if self.high_open else ']'}"

    def resolved(self, other: float) -> Range:
        """This range with its low end taken from the setting it depends on, whose value is ``other``."""
        return replace(self, low=self.low_scale * other, low_from=None)

    def contains(self, number: float) -> bool:
        """Whether a finite ``number`` lies inside (the ends open or closed as declared)."""
        too_low = number <= self.low if self.low_open else number < self.low
        too_high = number >= self.high if self.high_open else number > self.high
        return math.isfinite(number) and not too_low and not too_high

    def check(self, name: str, value: Any) -> float | int:
        """``value`` as a float (or int) inside the range, else a ValueError naming ``name``, value and range."""
        if self.low is None:
            raise TypeError(f"{name}'s range depends on {self.low_from}; resolve it first")
        if self.integer:
            if (
                isinstance(value, bool)
                or not isinstance(value, (int, np.integer))
                or not self.contains(value)
            ):
                raise ValueError(f"{name} must be an integer in {self.interval}, got {value!r}")
            return int(value)
        if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
            raise ValueError(f"{name} must be a number in {self.interval}, got {value!r}")
        if not self.contains(float(value)):
            raise ValueError(f"{name} must be in {self.interval}, got {value!r}")
        return float(value)


@dataclass(frozen=True)
class Choice:
    """One of a fixed set of values."""

    options: tuple[Any, ...]
    meaning: str = ""

    def check(self, name: str, value: Any) -> Any:
        if value not in self.options:
            raise ValueError(f"{name} must be one of {', '.join(map(repr, self.options))}, got {value!r}")
        return value


@dataclass(frozen=True)
class Flag:
    """True or False (NumPy booleans too, stored as ``bool``)."""

    meaning: str = ""

    def check(self, name: str, value: Any) -> bool:
        if not isinstance(value, (bool, np.bool_)):
            raise ValueError(f"{name} must be True or False, got {value!r}")
        return bool(value)


@dataclass(frozen=True)
class AnyInteger:
    """Any integer, e.g. a seed."""

    meaning: str = ""

    def check(self, name: str, value: Any) -> int:
        if not isinstance(value, (int, np.integer)) or isinstance(value, bool):
            raise ValueError(f"{name} must be an integer, got {value!r}")
        return int(value)


@dataclass(frozen=True)
class Sectors:
    """A (rows, cols) pair, each inside ``each``."""

    each: Range
    meaning: str = ""

    def check(self, name: str, value: Any) -> tuple[int, int]:
        if isinstance(value, (str, bytes)) or not isinstance(value, Sequence) or len(value) != 2:
            raise ValueError(f"{name} must be (rows, cols), got {value!r}")
        return (self.each.check(f"{name}[0]", value[0]), self.each.check(f"{name}[1]", value[1]))


@dataclass(frozen=True)
class BinEdges:
    """Increasing finite depths >= 0 m, at least two, stored as a tuple of floats."""

    meaning: str = ""

    def check(self, name: str, value: Any) -> tuple[float, ...]:
        edges = np.asarray(value, np.float64)
        if (
            edges.ndim != 1
            or len(edges) < 2
            or not np.all(np.isfinite(edges))
            or np.any(np.diff(edges) <= 0)
            or edges[0] < 0
        ):
            raise ValueError(f"{name} must be >= 2 increasing finite depths >= 0 m, got {value!r}")
        return tuple(float(edge) for edge in edges)


@dataclass(frozen=True)
class EstimatorArguments:
    """None or a mapping of :class:`estimator.FlowDepthEstimator` keyword arguments (their values the
    estimator checks itself), stored read-only."""

    meaning: str = ""

    def check(self, name: str, value: Any) -> Mapping[str, Any]:
        if value is None:
            return types.MappingProxyType({})
        if not isinstance(value, Mapping):
            raise ValueError(f"{name} must be a mapping of FlowDepthEstimator arguments, got {value!r}")
        allowed = [key for key in inspect.signature(FlowDepthEstimator).parameters if key != "intrinsics"]
        unknown = sorted(set(value) - set(allowed))
        if unknown:
            raise ValueError(f"{name} has unknown keys {unknown}; allowed: {', '.join(allowed)}")
        return types.MappingProxyType(dict(value))


def _setting(default: Any, rule: Rule) -> Any:
    return field(default=default, metadata={"rule": rule})


def _check_fields(settings: Any) -> None:
    """Check and normalise every field of a frozen settings dataclass in declaration order."""
    for item in fields(settings):
        rule = item.metadata["rule"]
        if isinstance(rule, Range) and rule.low_from is not None:
            rule = rule.resolved(getattr(settings, rule.low_from))
        object.__setattr__(settings, item.name, rule.check(item.name, getattr(settings, item.name)))


# The sensor's test variables: SensorSettings and EnvSettings both take their rules from here.
SENSOR_RULES: dict[str, Range] = {
    "attitude_jitter_deg": Range(
        0.0, 10.0, unit="deg", meaning="camera attitude disturbance per frame, ± per axis"
    ),
    "brightness": Range(0.0, 4.0, meaning="scene light level, 1 = daylight"),
    "rotation_error": Range(0.0, 1.0, meaning="relative error of the rotation told to the estimator"),
    "translation_error": Range(0.0, 1.0, meaning="relative error of the translation told to the estimator"),
}
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

    def __post_init__(self) -> None:
        _check_fields(self)


@dataclass(frozen=True)
class EnvSettings:
    """Every :class:`flownav_env.FlowNavEnv` constructor argument that shapes the world, the flight or the
    sensor, checked on construction (fields are checked in this order, so a range tied to another setting
    comes after it). Each rule carries a one-line meaning; FlowNavEnv's Arguments table explains them.

    Raises:
        ValueError: A value is outside its rule; the message names the setting, the value and the rule.
    """

    layout: str = _setting("field", Choice(LAYOUTS))
    obs_source: str = _setting("flow", Choice(OBS_SOURCES))
    observe_unresolved: bool = _setting(False, Flag())
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
    attitude_jitter_deg: float = _setting(0.0, SENSOR_RULES["attitude_jitter_deg"])
    brightness: float = _setting(1.0, SENSOR_RULES["brightness"])
    rotation_error: float = _setting(0.0, SENSOR_RULES["rotation_error"])
    translation_error: float = _setting(0.0, SENSOR_RULES["translation_error"])
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
    # Physics at 200 Hz or faster keeps the inner attitude loop stable.
    physics_timestep: float = _setting(0.004, Range(0.0005, 0.005, unit="s", meaning="MuJoCo timestep"))
    texture_seed: int = _setting(0, AnyInteger())
    estimator_kwargs: Mapping[str, Any] = _setting(None, EstimatorArguments())

    def __post_init__(self) -> None:
        _check_fields(self)

    @cached_property
    def sensor(self) -> SensorSettings:
        """The sensor variables of these settings."""
        return SensorSettings(**{name: getattr(self, name) for name in SENSOR_FIELDS})

    def with_sensor(self, **values: Any) -> EnvSettings:
        """These settings with some sensor variables changed (and checked).

        Raises:
            ValueError: A name is not a sensor variable, or a value is outside its range.
        """
        unknown = sorted(set(values) - set(SENSOR_FIELDS))
        if unknown:
            raise ValueError(f"not sensor settings: {unknown}; allowed: {', '.join(SENSOR_FIELDS)}")
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
