"""FlowNavEnv's settings as the env presents them, made from their one declaration (:mod:`flownav_env.settings`):
the Arguments table of its docstring, and the typed attributes (:class:`Setting`, :class:`SensorSetting`) that
read the settings.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import fields
from typing import Generic, Protocol, TypeVar, overload

from flownav_env.settings import SENSOR_FIELDS, SETTING_NAMES, EnvSettings

_T = TypeVar("_T")
_E = TypeVar("_E")


class _HasSettings(Protocol):
    settings: EnvSettings

    def set_sensor(self, **values: float) -> None: ...


# The docstring's marker that becomes the settings' rows of its Arguments table.
ROWS_MARKER = "{setting_rows}"


def format_default(value: object) -> str:
    """A default as the Arguments table writes it: ``"field"``, 0.12, (3, 5), None."""
    if isinstance(value, str):
        return f'``"{value}"``'
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, Sequence):
        return f"({', '.join(format_default(item) for item in value)})"
    return str(value)


def setting_rows(indent: str = "    ") -> str:
    """FlowNavEnv's Arguments table rows, one per :class:`EnvSettings` field in declaration order.

    Each row reads ``| ``name`` | default | meaning; allowed values |``; rows after the first start with
    ``indent``, so the result can replace a marker indented like the table.
    """
    rows = []
    for item in fields(EnvSettings):
        rule, meaning = item.metadata["rule"], item.metadata["meaning"]
        rows.append(f"| ``{item.name}`` | {format_default(item.default)} | {meaning}; {rule.describe()} |")
    return f"\n{indent}".join(rows)


class Setting(Generic[_T]):
    """An env attribute that reads ``env.settings.<its name>``, so the settings stay its one owner.

    Declared in the env's class body with its type, ``forward_speed: Setting[float] = Setting()``, so an IDE
    and mypy see it.
    """

    name = ""

    def __set_name__(self, owner: type, name: str) -> None:
        if name not in SETTING_NAMES and not hasattr(EnvSettings, name):
            raise ValueError(f"{owner.__name__}.{name} reads no setting of EnvSettings")
        self.name = name

    @overload
    def __get__(self, env: None, owner: type) -> Setting[_T]: ...
    @overload
    def __get__(self, env: _HasSettings, owner: type) -> _T: ...
    def __get__(self, env: _HasSettings | None, owner: type) -> _T | Setting[_T]:
        if env is None:
            return self
        value: _T = getattr(env.settings, self.name)
        return value

    def __set__(self, env: _HasSettings, value: _T) -> None:
        # A data descriptor, so an assignment cannot shadow the settings with an attribute that nothing reads.
        raise AttributeError(
            f"{self.name} is fixed when the env is made (pass it to gymnasium.make); only sensor settings change "
            "between episodes (set_sensor)"
        )


class SensorSetting(Setting[float]):
    """A sensor variable's attribute (:data:`~flownav_env.settings.SENSOR_FIELDS`): it reads the settings, and
    assigning it goes through ``env.set_sensor`` (checked, applied)."""

    def __set_name__(self, owner: type, name: str) -> None:
        if name not in SENSOR_FIELDS:
            raise ValueError(
                f"{owner.__name__}.{name} is no sensor setting; they are {', '.join(SENSOR_FIELDS)}"
            )
        self.name = name

    def __set__(self, env: _HasSettings, value: float) -> None:
        env.set_sensor(**{self.name: value})


def with_setting_rows(env_class: type[_E]) -> type[_E]:
    """Class decorator for FlowNavEnv: the docstring's :data:`ROWS_MARKER` becomes the settings' rows of its
    Arguments table (:func:`setting_rows`)."""
    if env_class.__doc__:  # None under python -OO
        env_class.__doc__ = env_class.__doc__.replace(ROWS_MARKER, setting_rows())
    return env_class
