"""YAML configs mapped one-to-one onto typed dataclasses, validated on load.

A config file is a YAML mapping whose keys are the fields of a dataclass (nested dataclasses are nested
mappings). Loading checks every key: an unknown key, a wrong type or a value outside the field's range raises
:class:`ConfigError` naming the file and the dotted key. Ranges are declared on the field::

    total_steps: int = field(default=100_000, metadata={"range": (1, None)})

Environment keyword arguments (``env:`` mappings) are checked against :class:`flownav_env.FlowNavEnv`'s own
validation, so the config surface of the env is its constructor, documented once.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, TypeVar

import yaml

T = TypeVar("T")


class ConfigError(ValueError):
    """A config file (or mapping) that does not fit its schema; the message names the source and the key."""


def load_config(path: str | Path, schema: type[T]) -> T:
    """Read a YAML file into the dataclass ``schema``.

    Args:
        path: the YAML file.
        schema: a dataclass type whose fields are the allowed keys.

    Returns:
        An instance of ``schema``.

    Raises:
        FileNotFoundError: the file does not exist.
        ValueError: the path is a directory.
        ConfigError: bad YAML, an unknown key, a wrong type or an out-of-range value.
    """
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"config {path} is a directory: give the path of a YAML file")
    if not path.is_file():
        raise FileNotFoundError(f"config file not found: {path}")
    try:
        data = yaml.safe_load(path.read_text()) or {}
    except yaml.YAMLError as error:
        raise ConfigError(f"{path}: not valid YAML: {error}") from error
    return from_mapping(data, schema, source=str(path))


def from_mapping(data: Any, schema: type[T], source: str = "<config>", prefix: str = "") -> T:
    """Build the dataclass ``schema`` from a mapping, validating every key (see :func:`load_config`)."""
    where = prefix.rstrip(".") or "top level"
    if not isinstance(data, Mapping):
        raise ConfigError(f"{source}: {where} must be a mapping of keys to values, got {type(data).__name__}")
    fields = {f.name: f for f in dataclasses.fields(schema) if f.init}
    unknown = sorted(set(data) - set(fields))
    if unknown:
        raise ConfigError(
            f"{source}: unknown key '{prefix}{unknown[0]}' (allowed at {where}: {', '.join(sorted(fields))})"
        )
    hints = typing.get_type_hints(schema)
    values = {}
    for name, value in data.items():
        key = f"{prefix}{name}"
        values[name] = _convert(value, hints[name], source, key)
        _check_range(values[name], fields[name].metadata.get("range"), source, key)
        _check_with(values[name], fields[name].metadata.get("check"), source, key)
    missing = [
        name
        for name, f in fields.items()
        if name not in values
        and f.default is dataclasses.MISSING
        and f.default_factory is dataclasses.MISSING
    ]
    if missing:
        raise ConfigError(f"{source}: missing required key '{prefix}{missing[0]}'")
    config = schema(**values)
    validate = getattr(config, "validate", None)
    if callable(validate):
        try:
            validate()
        except ValueError as error:
            raise ConfigError(f"{source}: {error}") from error
    return config


def _type_name(annotation: Any) -> str:
    return getattr(annotation, "__name__", None) or str(annotation).replace("typing.", "")


def _convert(value: Any, annotation: Any, source: str, key: str) -> Any:
    origin = typing.get_origin(annotation)
    args = typing.get_args(annotation)

    def wrong(expected: str) -> ConfigError:
        return ConfigError(f"{source}: key '{key}' must be {expected}, got {value!r}")

    if annotation is Any:
        return value
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        options = [a for a in args if a is not type(None)]
        errors = []
        for option in options:
            try:
                return _convert(value, option, source, key)
            except ConfigError as error:
                errors.append(error)
        raise wrong(" or ".join(_type_name(a) for a in args))
    if origin is typing.Literal:
        if value not in args:
            raise wrong("one of " + ", ".join(repr(a) for a in args))
        return value
    if dataclasses.is_dataclass(annotation):
        return from_mapping(value, annotation, source, prefix=f"{key}.")
    if annotation is bool:
        if not isinstance(value, bool):
            raise wrong("true or false")
        return value
    if annotation is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise wrong("an integer")
        return value
    if annotation is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise wrong("a finite number")
        return float(value)
    if annotation is str:
        if not isinstance(value, str):
            raise wrong("a string")
        return value
    if origin in (list, tuple):
        if not isinstance(value, (list, tuple)):
            raise wrong(f"a list of {_type_name(args[0]) if args else 'values'}")
        item_type = args[0] if args else Any
        items = [_convert(item, item_type, source, f"{key}[{i}]") for i, item in enumerate(value)]
        return tuple(items) if origin is tuple else items
    if origin is dict:
        if not isinstance(value, Mapping):
            raise wrong("a mapping")
        return dict(value)
    raise TypeError(f"config schema uses an unsupported type {annotation!r} for '{key}'")


def _check_range(value: Any, bounds: tuple[float | None, float | None] | None, source: str, key: str) -> None:
    if bounds is None or value is None:
        return
    low, high = bounds
    items = value if isinstance(value, (list, tuple)) else [value]
    for item in items:
        if (low is not None and item < low) or (high is not None and item > high):
            interval = f"[{'-inf' if low is None else low}, {'inf' if high is None else high}]"
            raise ConfigError(f"{source}: key '{key}' must be in {interval}, got {value!r}")


def _check_with(value: Any, check: Callable[[str, Any], Any] | None, source: str, key: str) -> None:
    if check is None or value is None:
        return
    for item in value if isinstance(value, (list, tuple)) else [value]:
        try:
            check(key.rsplit(".", 1)[-1], item)
        except ValueError as error:
            raise ConfigError(f"{source}: key '{key}': {error}") from error


def field_range(low: float | None = None, high: float | None = None, **kwargs: Any) -> Any:
    """A dataclass field whose value (or each of its items) must lie in [low, high]."""
    return dataclasses.field(metadata={"range": (low, high)}, **kwargs)


def checked_field(check: Callable[[str, Any], Any], **kwargs: Any) -> Any:
    """A dataclass field whose value (or each of its items) must pass ``check(name, value)``, which raises
    ValueError otherwise: for ranges owned elsewhere, such as a setting's rule in the env (``flownav_env.settings_check.setting_check``)."""
    return dataclasses.field(metadata={"check": check}, **kwargs)
