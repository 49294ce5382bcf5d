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


def _wrong(value: Any, expected: str, source: str, key: str) -> ConfigError:
    return ConfigError(f"{source}: key '{key}' must be {expected}, got {value!r}")


def _is_bool(value: Any) -> bool:
    return isinstance(value, bool)


def _is_integer(value: Any) -> bool:
    # bool is a subclass of int, but ``true`` for a count is a mistake in the YAML.
    return isinstance(value, int) and not isinstance(value, bool)


def _is_finite_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _is_string(value: Any) -> bool:
    return isinstance(value, str)


def _unchanged(value: Any) -> Any:
    return value


# Each scalar type a schema may use: the test a value must pass, what the error says it must be, and how the
# accepted value is stored (a YAML integer given for a float field becomes a float).
_SCALARS: dict[Any, tuple[Callable[[Any], bool], str, Callable[[Any], Any]]] = {
    bool: (_is_bool, "true or false", _unchanged),
    int: (_is_integer, "an integer", _unchanged),
    float: (_is_finite_number, "a finite number", float),
    str: (_is_string, "a string", _unchanged),
}


def _convert(value: Any, annotation: Any, source: str, key: str) -> Any:
    """``value`` checked against the type ``annotation`` and converted to it; ConfigError names ``key``."""
    origin = typing.get_origin(annotation)
    if annotation is Any:
        return value
    if origin in (typing.Union, types.UnionType):
        return _convert_union(value, typing.get_args(annotation), source, key)
    if origin is typing.Literal:
        return _convert_literal(value, typing.get_args(annotation), source, key)
    if dataclasses.is_dataclass(annotation):
        return from_mapping(value, annotation, source, prefix=f"{key}.")
    if annotation in _SCALARS:
        accepts, expected, stored = _SCALARS[annotation]
        if not accepts(value):
            raise _wrong(value, expected, source, key)
        return stored(value)
    if origin in (list, tuple):
        return _convert_sequence(value, origin, typing.get_args(annotation), source, key)
    if origin is dict:
        if not isinstance(value, Mapping):
            raise _wrong(value, "a mapping", source, key)
        return dict(value)
    raise TypeError(f"config schema uses an unsupported type {annotation!r} for '{key}'")


def _convert_union(value: Any, options: tuple[Any, ...], source: str, key: str) -> Any:
    """The first option of a union that ``value`` fits, in the order the annotation lists them."""
    if value is None and type(None) in options:
        return None
    for option in options:
        if option is type(None):
            continue
        try:
            return _convert(value, option, source, key)
        except ConfigError:
            pass
    raise _wrong(value, " or ".join(_type_name(a) for a in options), source, key)


def _convert_literal(value: Any, allowed: tuple[Any, ...], source: str, key: str) -> Any:
    if value not in allowed:
        raise _wrong(value, "one of " + ", ".join(repr(a) for a in allowed), source, key)
    return value


def _convert_sequence(
    value: Any, origin: Any, args: tuple[Any, ...], source: str, key: str
) -> list[Any] | tuple[Any, ...]:
    if not isinstance(value, (list, tuple)):
        raise _wrong(value, f"a list of {_type_name(args[0]) if args else 'values'}", source, key)
    item_type = args[0] if args else Any
    items = [_convert(item, item_type, source, f"{key}[{i}]") for i, item in enumerate(value)]
    return tuple(items) if origin is tuple else items


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
