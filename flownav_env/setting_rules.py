"""The rules a FlowNav setting obeys: each checks a value, normalises it, names what is wrong and describes
what it allows (for FlowNavEnv's Arguments table).

:mod:`flownav_env.settings` declares every setting as a dataclass field carrying its default, its rule and its
meaning (:func:`setting_field`) and checks them all on construction; the rules live here so that the
settings module holds only the settings. Error messages name the parameter, the value received and the
allowed values.
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from estimator import CameraIntrinsics, FlowDepthEstimator

if TYPE_CHECKING:
    from _typeshed import DataclassInstance

_PROBE_CAMERA = CameraIntrinsics.from_fov(16, 16, 60.0)


class Rule(Protocol):
    """What a setting's metadata holds: a check that returns the value in its stored form."""

    def check(self, name: str, value: object) -> object: ...

    def describe(self) -> str:
        """What the rule allows, as the Arguments table writes it."""
        ...


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
    low_from: str | None = None
    low_scale: float = 1.0

    @property
    def interval(self) -> str:
        """The interval as the error messages and the docs write it, e.g. ``(0.0, 5.0]``."""
        return f"{'(' if self.low_open else '['}{self.low}, {self.high}{')' if self.high_open else ']'}"

    def describe(self) -> str:
        """E.g. ``in (0, 5] m/s``, ``in (2 · ``obstacle_radius``, 10] m`` or ``≥ 0``."""
        unit = f" {self.unit}" if self.unit else ""
        if self.low_from is not None:
            scale = "" if self.low_scale == 1.0 else f"{self.low_scale:g} · "
            low = f"{scale}``{self.low_from}``"
        elif math.isinf(self.high):
            return f"≥ {self.low:g}{unit}"
        else:
            low = f"{self.low:g}"
        kind = "an integer " if self.integer else ""
        opened, closed = "(" if self.low_open else "[", ")" if self.high_open else "]"
        return f"{kind}in {opened}{low}, {self.high:g}{closed}{unit}"

    def resolved(self, other: float) -> Range:
        """This range with its low end taken from the setting it depends on, whose value is ``other``."""
        return replace(self, low=self.low_scale * other, low_from=None)

    def contains(self, number: float) -> bool:
        """Whether a finite ``number`` lies inside (the ends open or closed as declared)."""
        low = self.low
        if low is None:
            raise TypeError(f"this range's low end depends on {self.low_from}; resolve it first")
        too_low = number <= low if self.low_open else number < low
        too_high = number >= self.high if self.high_open else number > self.high
        return math.isfinite(number) and not too_low and not too_high

    def check(self, name: str, value: object) -> float | int:
        """``value`` as a float (or int) inside the range, else a ValueError naming ``name``, value and range."""
        return self.check_int(name, value) if self.integer else self.check_float(name, value)

    def check_int(self, name: str, value: object) -> int:
        """``value`` as an int inside the range (an integer range's :meth:`check`)."""
        self._require_low(name)
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, np.integer))
            or not self.contains(int(value))
        ):
            raise ValueError(f"{name} must be an integer in {self.interval}, got {value!r}")
        return int(value)

    def check_float(self, name: str, value: object) -> float:
        """``value`` as a float inside the range (a real range's :meth:`check`)."""
        self._require_low(name)
        if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
            raise ValueError(f"{name} must be a number in {self.interval}, got {value!r}")
        if not self.contains(float(value)):
            raise ValueError(f"{name} must be in {self.interval}, got {value!r}")
        return float(value)

    def _require_low(self, name: str) -> None:
        if self.low is None:
            raise TypeError(f"{name}'s range depends on {self.low_from}; resolve it first")


@dataclass(frozen=True)
class Choice:
    """One of a fixed set of values."""

    options: tuple[object, ...]

    def describe(self) -> str:
        return "one of " + ", ".join(f'``"{option}"``' for option in self.options)

    def check(self, name: str, value: object) -> object:
        if value not in self.options:
            raise ValueError(f"{name} must be one of {', '.join(map(repr, self.options))}, got {value!r}")
        return value


@dataclass(frozen=True)
class Flag:
    """True or False (NumPy booleans too, stored as ``bool``)."""

    def describe(self) -> str:
        return "True or False"

    def check(self, name: str, value: object) -> bool:
        if not isinstance(value, (bool, np.bool_)):
            raise ValueError(f"{name} must be True or False, got {value!r}")
        return bool(value)


@dataclass(frozen=True)
class AnyInteger:
    """Any integer, e.g. a seed."""

    def describe(self) -> str:
        return "any integer"

    def check(self, name: str, value: object) -> int:
        if not isinstance(value, (int, np.integer)) or isinstance(value, bool):
            raise ValueError(f"{name} must be an integer, got {value!r}")
        return int(value)


@dataclass(frozen=True)
class Sectors:
    """A (rows, cols) pair of integers, each inside the integer range ``each``."""

    each: Range

    def describe(self) -> str:
        return f"(rows, cols), each {self.each.describe()}"

    def check(self, name: str, value: object) -> tuple[int, int]:
        if isinstance(value, (str, bytes)) or not isinstance(value, Sequence) or len(value) != 2:
            raise ValueError(f"{name} must be (rows, cols), got {value!r}")
        return (self.each.check_int(f"{name}[0]", value[0]), self.each.check_int(f"{name}[1]", value[1]))


@dataclass(frozen=True)
class BinEdges:
    """Increasing finite depths >= 0 m, at least two, stored as a tuple of floats."""

    def describe(self) -> str:
        return "at least two increasing depths ≥ 0 m"

    def check(self, name: str, value: object) -> tuple[float, ...]:
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


class FrozenMapping(Mapping[str, object]):
    """A read-only mapping that, unlike ``types.MappingProxyType``, pickles and copies: settings travel to
    worker processes inside ``gymnasium.make``'s keywords."""

    __slots__ = ("_items",)

    def __init__(self, items: Mapping[str, object]) -> None:
        self._items = dict(items)

    def __getitem__(self, key: str) -> object:
        return self._items[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self._items)

    def __len__(self) -> int:
        return len(self._items)

    def __repr__(self) -> str:
        return repr(self._items)


@dataclass(frozen=True)
class EstimatorArguments:
    """None or a mapping of :class:`estimator.FlowDepthEstimator` keyword arguments, stored read-only. Their
    values are checked by building an estimator on a small probe camera (none of its arguments' ranges
    depends on the camera), so the message is the estimator's own."""

    def describe(self) -> str:
        return "None or a mapping of ``estimator.FlowDepthEstimator`` keyword arguments"

    def check(self, name: str, value: object) -> Mapping[str, object]:
        if value is None:
            return FrozenMapping({})
        if not isinstance(value, Mapping):
            raise ValueError(f"{name} must be a mapping of FlowDepthEstimator arguments, got {value!r}")
        allowed = [key for key in inspect.signature(FlowDepthEstimator).parameters if key != "intrinsics"]
        unknown = sorted(set(value) - set(allowed))
        if unknown:
            raise ValueError(f"{name} has unknown keys {unknown}; allowed: {', '.join(allowed)}")
        FlowDepthEstimator(_PROBE_CAMERA, **value)
        return FrozenMapping(value)


# Returned as Any, as dataclasses.field's own result is: the field stands in for a value of the field's type (a
# default of None stands for an empty mapping of estimator arguments, so the default's type is not the field's).
def setting_field(default: object, rule: Rule, meaning: str) -> Any:
    """A settings dataclass field: its default, the rule that checks it and what it means (one line of
    FlowNavEnv's Arguments table), declared together once."""
    return field(default=default, metadata={"rule": rule, "meaning": meaning})


def check_fields(settings: DataclassInstance) -> None:
    """Check and normalise every field of a frozen settings dataclass in declaration order."""
    for item in fields(settings):
        rule = item.metadata["rule"]
        if isinstance(rule, Range) and rule.low_from is not None:
            rule = rule.resolved(getattr(settings, rule.low_from))
        object.__setattr__(settings, item.name, rule.check(item.name, getattr(settings, item.name)))
