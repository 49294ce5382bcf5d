"""YAML configs onto dataclasses: what loads, and the one-line message of each kind of refusal."""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import pytest

from agents.common.yaml_config import (
    ConfigError,
    checked_field,
    field_range,
    from_mapping,
    interval,
    load_config,
    within,
)


def _even(name: str, value: Any) -> None:
    if value % 2:
        raise ValueError(f"{name} must be even, got {value}")


@dataclass
class Point:
    x: float = field_range(-10.0, 10.0, default=0.0)
    tag: str = ""


@dataclass
class Limits:
    low: float = 0.0
    high: float = 1.0

    def validate(self) -> None:
        if self.low > self.high:
            raise ValueError(f"key 'limits' must have low <= high, got {self.low} > {self.high}")


@dataclass
class Run:
    name: str
    steps: int = field_range(1, 100, default=10)
    rate: float = field_range(0.0, None, default=0.5)
    verbose: bool = False
    mode: Literal["fast", "slow", "exact"] = "fast"
    layers: list[int] = field_range(1, 64, default_factory=lambda: [8, 8])
    pairs: list[int] = checked_field(_even, default_factory=list)
    scale: float | None = field_range(0.0, 1.0, default=None)
    extra: dict[str, Any] = field(default_factory=dict)
    origin: Point = field(default_factory=Point)
    points: list[Point] = field(default_factory=list)
    limits: Limits | None = None


def test_a_mapping_becomes_the_dataclass_with_its_defaults_and_nested_instances() -> None:
    run = from_mapping(
        {"name": "a", "rate": 2, "points": [{"x": 1}], "limits": {"high": 3}, "extra": {"k": [1]}}, Run
    )
    assert run == Run(name="a", rate=2.0, points=[Point(x=1.0)], limits=Limits(high=3.0), extra={"k": [1]})
    assert type(run.rate) is float and type(run.points[0].x) is float  # a YAML integer for a float field
    assert isinstance(run.origin, Point) and dataclasses.asdict(run)["origin"] == {"x": 0.0, "tag": ""}
    assert from_mapping({"name": "b", "scale": None, "limits": None}, Run).limits is None


def test_a_config_file_loads_and_an_empty_one_is_an_empty_mapping(tmp_path: Path) -> None:
    path = tmp_path / "run.yaml"
    path.write_text("name: r\nmode: exact\nlayers: [4]\norigin: {x: -2.5}\n")
    assert load_config(path, Run) == Run(name="r", mode="exact", layers=[4], origin=Point(x=-2.5))
    path.write_text("")
    assert load_config(path, Point) == Point()
    with pytest.raises(ValueError, match=r"is a directory: give the path of a YAML file"):
        load_config(tmp_path, Run)


@pytest.mark.parametrize(
    ("data", "message"),
    [
        # An unknown key, at the top and below it, lists the keys allowed there.
        (
            {"name": "a", "stpes": 3},
            "unknown key 'stpes' (allowed at top level: extra, layers, limits, mode, name, origin, pairs, "
            "points, rate, scale, steps, verbose); did you mean 'steps'?",
        ),
        ({"name": "a", "origin": {"y": 1}}, "unknown key 'origin.y' (allowed at origin: tag, x)"),
        ({"name": "a", "points": [{}, {"z": 1}]}, "unknown key 'points[1].z' (allowed at points[1]: tag, x)"),
        # A missing required key.
        ({"steps": 3}, "missing required key 'name'"),
        # A wrong type names what the key must be and the value given.
        ({"name": "a", "steps": "3"}, "key 'steps' must be an integer, got '3'"),
        ({"name": "a", "steps": True}, "key 'steps' must be an integer, got True"),
        ({"name": "a", "steps": 2.0}, "key 'steps' must be an integer, got 2.0"),
        ({"name": "a", "rate": "fast"}, "key 'rate' must be a finite number, got 'fast'"),
        ({"name": "a", "rate": float("inf")}, "key 'rate' must be a finite number, got inf"),
        ({"name": "a", "verbose": "yes please"}, "key 'verbose' must be true or false, got 'yes please'"),
        ({"name": 7}, "key 'name' must be a string, got 7"),
        ({"name": "a", "layers": 8}, "key 'layers' must be a list, got 8"),
        ({"name": "a", "layers": [8, "x"]}, "key 'layers[1]' must be an integer, got 'x'"),
        ({"name": "a", "extra": [1]}, "key 'extra' must be a mapping, got [1]"),
        ({"name": "a", "origin": 3}, "key 'origin' must be a mapping, got 3"),
        ({"name": "a", "mode": "quick"}, "key 'mode' must be one of 'fast', 'slow', 'exact', got 'quick'"),
        ({"name": "a", "scale": "half"}, "key 'scale' must be a finite number, got 'half'"),
        ([1, 2], "the top level must be a mapping, got [1, 2]"),
        # A value outside its field's range names the range (an open end is inf).
        ({"name": "a", "steps": 0}, "key 'steps' must be in [1, 100], got 0"),
        ({"name": "a", "rate": -0.1}, "key 'rate' must be in [0.0, inf], got -0.1"),
        ({"name": "a", "layers": [8, 65]}, "key 'layers' must be in [1, 64], got [8, 65]"),
        ({"name": "a", "scale": 1.5}, "key 'scale' must be in [0.0, 1.0], got 1.5"),
        ({"name": "a", "points": [{"x": 11}]}, "key 'points[0].x' must be in [-10.0, 10.0], got 11"),
        # A rule owned elsewhere speaks for itself, after the key.
        ({"name": "a", "pairs": [2, 3]}, "key 'pairs': pairs must be even, got 3"),
        # A dataclass's own validate() says the whole line.
        ({"name": "a", "limits": {"low": 2.0}}, "key 'limits' must have low <= high, got 2.0 > 1.0"),
    ],
)
def test_each_refusal_is_one_line_naming_the_source_the_key_and_the_value(data: Any, message: str) -> None:
    with pytest.raises(ConfigError, match=f"^run.yaml: {re.escape(message)}$") as error:
        from_mapping(data, Run, source="run.yaml")
    assert isinstance(error.value, ValueError) and "\n" not in str(error.value)


def test_a_file_error_names_the_file(tmp_path: Path) -> None:
    path = tmp_path / "run.yaml"
    path.write_text("name: a\nsteps: 500\n")
    with pytest.raises(
        ConfigError, match=rf"^{re.escape(str(path))}: key 'steps' must be in \[1, 100\], got 500$"
    ):
        load_config(path, Run)
    path.write_text("name: [a\n")
    with pytest.raises(ConfigError, match=r"not valid YAML"):
        load_config(path, Run)


def test_the_range_helpers_read_an_open_end_as_unbounded() -> None:
    assert within(5, (1, 5)) and within(-1e9, (None, 0)) and within(1e9, (0, None))
    assert not within(0, (1, None)) and not within(6, (None, 5))
    assert interval((1, 64)) == "[1, 64]" and interval((None, 0.5)) == "[-inf, 0.5]"
    assert interval((0, None)) == "[0, inf]"
