"""YAML configs mapped one-to-one onto typed dataclasses, validated on load by pydantic.

A config file is a YAML mapping whose keys are the fields of a dataclass (nested dataclasses are nested
mappings). Loading checks every key: an unknown key, a wrong type, a value outside the field's range or a
missing required key raises :class:`ConfigError`, one line naming the file, the dotted key, the value and what
was allowed. A field's range is declared once, on the field::

    total_steps: int = field_range(1, None, default=100_000)

and a value whose rule another module owns (an env setting) is checked by that module's function::

    brightness: float = checked_field(setting_check("brightness"), default=1.0)

pydantic rather than cattrs: its strict mode already refuses what a YAML typo gives (``true`` for a count,
``"5"`` for a number, ``.inf``), and it reports each error with the key's path and the value, which is all
the one-line messages need; cattrs would leave the types and ranges to hooks written here. The schemas stay
plain dataclasses, so callers keep ``dataclasses.asdict``, equality and direct construction.
"""

from __future__ import annotations

import dataclasses
import difflib
import functools
import types
import typing
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any, Literal, TypeVar, cast

import yaml
from pydantic import AfterValidator, BeforeValidator, ConfigDict, TypeAdapter, ValidationError, with_config
from pydantic_core import ErrorDetails, PydanticCustomError
from typing_extensions import NotRequired, TypedDict  # pydantic takes typing's TypedDict only from 3.12

T = TypeVar("T")
V = TypeVar("V")
Bounds = tuple[float | None, float | None]
Check = Callable[[str, Any], object]

# A YAML typo should fail, not be coerced: no "5" for a number, no true for a count, no .inf or .nan; a YAML
# integer is still a float field's value (stored as a float).
_STRICT = ConfigDict(strict=True, allow_inf_nan=False)

# What a value of each type must be, for pydantic's type errors.
_EXPECTED = {
    "bool_type": "true or false",
    "int_type": "an integer",
    "float_type": "a finite number",
    "finite_number": "a finite number",
    "string_type": "a string",
    "list_type": "a list",
    "dict_type": "a mapping",
}

# Each error as one line after "<source>: ". The fields: subject ("key 'ppo.gamma'", or "the top level"), key,
# prefix (the key and a dot, for a key below it), where ("ppo" or "top level"), input (the bad value), msg
# (pydantic's or this module's), expected (from _EXPECTED), choices (a Literal's) and the error's context.
_TEMPLATES = {
    "unknown_key": "unknown key '{prefix}{name}' (allowed at {where}: {allowed}){hint}",
    "missing": "missing required key '{key}'",
    "out_of_range": "{subject} {msg}, got {input!r}",
    "setting": "{subject}: {msg}",
    "value_error": "{error}",
    "literal_error": "{subject} must be one of {choices}, got {input!r}",
    **dict.fromkeys(_EXPECTED, "{subject} must be {expected}, got {input!r}"),
}
_OTHER = "{subject}: {msg}, got {input!r}"


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
        ConfigError: bad YAML, an unknown key, a wrong type, an out-of-range value or a missing required key.
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


def from_mapping(data: object, schema: type[T], source: str = "<config>") -> T:
    """Build the dataclass ``schema`` from a mapping, validating every key (see :func:`load_config`); each
    dataclass's ``validate()`` method, if it has one, runs last and its ValueError becomes a ConfigError."""
    # Building the adapter takes milliseconds: the per-dataclass mappings under it are cached. The mapping stands
    # in for the dataclass (pydantic builds a T from it), which the annotation of _pydantic_type cannot say.
    pydantic_type = cast("type[T]", _pydantic_type(schema))
    adapter: TypeAdapter[T] = TypeAdapter(pydantic_type)
    try:
        return adapter.validate_python(data)
    except ValidationError as error:
        raise ConfigError(f"{source}: {_message(error.errors()[0])}") from error


# Returned as Any, as dataclasses.field's own result is: the field stands in for a value of the field's type.
def field_range(
    low: float | None = None,
    high: float | None = None,
    *,
    default: object = dataclasses.MISSING,
    default_factory: Callable[[], object] | None = None,
) -> Any:
    """A dataclass field whose value (or each of its items) must lie in [low, high]; None is unbounded. Its
    ``default`` or ``default_factory`` as ``dataclasses.field``'s (neither: a required field)."""
    return _field({"range": (low, high)}, default, default_factory)


def checked_field(
    check: Check,
    *,
    default: object = dataclasses.MISSING,
    default_factory: Callable[[], object] | None = None,
) -> Any:
    """A dataclass field whose value (or each of its items) must pass ``check(name, value)``, which raises
    ValueError otherwise: for ranges owned elsewhere, such as a setting's rule in the env
    (``flownav_env.settings_check.setting_check``). ``default`` and ``default_factory`` as in :func:`field_range`."""
    return _field({"check": check}, default, default_factory)


def _field(
    metadata: dict[str, object], default: object, default_factory: Callable[[], object] | None
) -> object:
    if default_factory is not None:
        return dataclasses.field(default_factory=default_factory, metadata=metadata)
    return dataclasses.field(default=default, metadata=metadata)


def within(value: float, bounds: Bounds) -> bool:
    """Whether ``value`` lies in the closed interval ``bounds`` (a None end is unbounded)."""
    low, high = bounds
    return (low is None or value >= low) and (high is None or value <= high)


def interval(bounds: Bounds) -> str:
    """``bounds`` as the messages write it: ``[1, 64]``, ``[0, inf]``."""
    low, high = bounds
    return f"[{'-inf' if low is None else low}, {'inf' if high is None else high}]"


def _pydantic_type(hint: object) -> object:
    """The annotation ``hint`` with each dataclass in it (``Case``, ``list[Case]``, ``Case | None``) replaced by
    the mapping that validates it and builds it."""
    if isinstance(hint, type) and dataclasses.is_dataclass(hint):
        return _dataclass_mapping(hint)
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin is None or origin is Literal or not args:
        return hint
    if origin is types.UnionType:
        origin = typing.Union
    return origin[tuple(_pydantic_type(arg) for arg in args)]


@functools.cache
def _dataclass_mapping(schema: type) -> object:
    """A TypedDict of ``schema``'s fields (each with its checks), refusing keys it lacks, that validates into
    an instance of ``schema``: absent keys take the dataclass's own defaults."""
    hints = typing.get_type_hints(schema)
    keys = {f.name: _key_type(hints[f.name], f) for f in dataclasses.fields(schema) if f.init}
    # TypedDict's functional form, with keys known only here (the static checker wants a literal).
    mapping = with_config(_STRICT)(cast(Any, TypedDict)(schema.__name__, keys))
    return Annotated[
        mapping,
        BeforeValidator(functools.partial(_known_keys, sorted(keys))),
        AfterValidator(_builder(schema)),
    ]


def _key_type(hint: object, field: dataclasses.Field[object]) -> object:
    checks = []
    if "range" in field.metadata:
        checks.append(AfterValidator(functools.partial(_in_range, field.metadata["range"])))
    if "check" in field.metadata:
        checks.append(AfterValidator(functools.partial(_passes, field.metadata["check"], field.name)))
    key_type = Annotated[(_pydantic_type(hint), *checks)] if checks else _pydantic_type(hint)
    required = field.default is dataclasses.MISSING and field.default_factory is dataclasses.MISSING
    return key_type if required else NotRequired[key_type]


def _builder(schema: type[T]) -> Callable[[dict[str, object]], T]:
    def build(values: dict[str, object]) -> T:
        config = schema(**values)
        validate = getattr(config, "validate", None)
        if callable(validate):
            validate()  # its ValueError reaches the message whole (value_error)
        return config

    return build


def _known_keys(allowed: list[str], data: object) -> object:
    """``data`` unchanged; an unknown key in it is an error listing the allowed ones. (A non-mapping is left
    to the TypedDict, which says it must be a mapping.)"""
    if isinstance(data, dict):
        unknown = sorted(str(key) for key in data if key not in allowed)
        if unknown:
            close = difflib.get_close_matches(unknown[0], allowed, n=1)
            raise PydanticCustomError(
                "unknown_key",
                "unknown key {name}",
                {
                    "name": unknown[0],
                    "allowed": ", ".join(allowed),
                    "hint": f"; did you mean '{close[0]}'?" if close else "",
                },
            )
    return data


def _items(value: V | list[V] | None) -> list[V]:
    """The values a field's rule applies to: each item of a list (of levels, of [low, high]), else the value."""
    if value is None:
        return []
    return cast(list[V], value) if isinstance(value, list) else [value]


def _in_range(bounds: Bounds, value: float | list[float] | None) -> float | list[float] | None:
    if not all(within(item, bounds) for item in _items(value)):
        raise PydanticCustomError("out_of_range", "must be in {interval}", {"interval": interval(bounds)})
    return value


def _passes(check: Check, name: str, value: object) -> object:
    for item in _items(value):
        try:
            check(name, item)
        except ValueError as error:
            raise PydanticCustomError("setting", "{error}", {"error": str(error)}) from error
    return value


def _message(error: ErrorDetails) -> str:
    """pydantic's ``error`` as this module's one line (without the source): see _TEMPLATES."""
    key = "".join(f"[{part}]" if isinstance(part, int) else f".{part}" for part in error["loc"]).lstrip(".")
    context = error.get("ctx", {})
    # pydantic writes a Literal's values "'a', 'b' or 'c'"; the messages list them "'a', 'b', 'c'".
    choices = ", ".join(str(context.get("expected", "")).rsplit(" or ", 1))
    fields = {
        **context,
        "key": key,
        "subject": f"key '{key}'" if key else "the top level",
        "prefix": f"{key}." if key else "",
        "where": key or "top level",
        "input": error["input"],
        "msg": error["msg"],
        "expected": _EXPECTED.get(error["type"], ""),
        "choices": choices,
    }
    return _TEMPLATES.get(error["type"], _OTHER).format(**fields)
