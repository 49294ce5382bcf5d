"""FlowNavEnv's settings as the env presents them, made from their one declaration (:mod:`flownav_env.settings`):
the Arguments table of its docstring, and its attributes that read the settings.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import fields

from flownav_env.settings import SENSOR_FIELDS, EnvSettings

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


def settings_property(name: str, sensor: bool = False) -> property:
    """An env attribute that reads ``env.settings.<name>``, so the settings stay its one owner; a sensor
    variable's attribute can be assigned, which goes through ``env.set_sensor`` (checked, applied)."""
    setter = (lambda env, value: env.set_sensor(**{name: value})) if sensor else None
    return property(lambda env: getattr(env.settings, name), setter, doc=f"``settings.{name}``")


def with_settings(env_class: type) -> type:
    """Class decorator for FlowNavEnv: each sensor setting becomes an attribute that reads the settings and
    assigns through ``set_sensor``, and the docstring's :data:`ROWS_MARKER` becomes the settings' rows of its
    Arguments table (:func:`setting_rows`)."""
    for name in SENSOR_FIELDS:
        setattr(env_class, name, settings_property(name, sensor=True))
    if env_class.__doc__:  # None under python -OO
        env_class.__doc__ = env_class.__doc__.replace(ROWS_MARKER, setting_rows())
    return env_class
