"""Checking FlowNav settings by name, without building an env: the one validator behind ``FlowNavEnv``'s
keywords, ``gymnasium.make``, the YAML configs' ``env:`` mappings, sweeps, training randomisation and playback.

Names are checked against :class:`flownav_env.settings.EnvSettings`' fields, values by the rules those fields
carry (:mod:`flownav_env.setting_rules`); MuJoCo is never touched here.
"""

from __future__ import annotations

import difflib
from collections.abc import Callable, Mapping
from dataclasses import fields, replace
from typing import Any, cast

from flownav_env.setting_rules import BinEdges, Choice, Range, Rule, Sectors
from flownav_env.settings import SETTING_NAMES, EnvSettings

RENDER_MODES = ("rgb_array",)
# Every keyword FlowNavEnv and gymnasium.make take besides ``settings`` itself.
ENV_ARGUMENTS = (*SETTING_NAMES, "render_mode")
_RULES: dict[str, Rule] = {item.name: item.metadata["rule"] for item in fields(EnvSettings)}
_DEFAULTS: dict[str, Any] = {item.name: item.default for item in fields(EnvSettings)}


def unknown_setting_message(name: str, known: tuple[str, ...] = SETTING_NAMES) -> str:
    """``unknown setting 'name'; known: ...``, with the nearest known name when one is close."""
    close = difflib.get_close_matches(str(name), known, n=1)
    hint = f" (did you mean {close[0]!r}?)" if close else ""
    return f"unknown setting {name!r}; known: {', '.join(known)}{hint}"


def _rule(name: str) -> Rule:
    if name not in _RULES:
        raise ValueError(unknown_setting_message(name))
    return _RULES[name]


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
        rule = rule.resolved(others.get(rule.low_from, _DEFAULTS[rule.low_from]))
    return rule


def check_setting(name: str, value: object, **others: float) -> object:
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


def setting_check(setting: str) -> Callable[[str, object], object]:
    """A check of a config value that holds setting ``setting``: ``check(key, value)`` returns ``value``
    normalised by :func:`check_setting`, or a list of such values when ``value`` is a list or tuple of them (a
    list of levels or a ``[low, high]`` interval; a (rows, cols) or bin-edge setting's own value is a
    sequence, so it is checked whole). ``key``, the config's name for the value, is not used: the message
    names the setting.

    Raises:
        ValueError: ``setting`` is not a setting (at once, not when checking).
    """
    whole = isinstance(_rule(setting), (Sectors, BinEdges))

    def check(_key: str, value: object) -> object:
        if isinstance(value, (list, tuple)) and not whole:
            return [check_setting(setting, item) for item in value]
        return check_setting(setting, value)

    return check


def check_render_mode(render_mode: object) -> str | None:
    """``render_mode`` if FlowNavEnv supports it (None or one of :data:`RENDER_MODES`).

    Raises:
        ValueError: Any other render mode.
    """
    if render_mode is None:
        return None
    Choice(RENDER_MODES).check("render_mode", render_mode)
    return str(render_mode)


def settings_with(settings: EnvSettings | None, overrides: Mapping[str, object]) -> EnvSettings:
    """``settings`` (or the defaults, for None) with the fields named in ``overrides`` replaced, all checked:
    what FlowNavEnv's constructor does with its arguments.

    Raises:
        ValueError: ``settings`` is not an :class:`EnvSettings`, an override names no setting, or a value
            breaks its rule.
    """
    if settings is not None and not isinstance(settings, EnvSettings):
        raise ValueError(
            f"settings must be a flownav_env.settings.EnvSettings or None, got {type(settings).__name__} "
            "(pass single settings by keyword: FlowNavEnv(layout='corridor'))"
        )
    for name in overrides:
        if name not in _RULES:
            raise ValueError(
                f"FlowNavEnv takes settings=, render_mode= and settings by name: {unknown_setting_message(name)}"
            )
    # Any value may come in: EnvSettings checks each against its rule as it is built.
    checked_on_build = cast("dict[str, Any]", overrides)
    return EnvSettings(**checked_on_build) if settings is None else replace(settings, **checked_on_build)


def check_env_kwargs(env_kwargs: Mapping[str, object], source: str, key: str = "env") -> dict[str, object]:
    """Check a config's ``env:`` mapping (FlowNavEnv keywords) by name and value, as the env would, without
    building one.

    Args:
        env_kwargs: Keywords for ``FlowNavEnv`` / ``gymnasium.make``.
        source: What the mapping came from (a config file's path, ``"command line"``), for the message.
        key: The mapping's own key in ``source``.

    Returns:
        A copy of ``env_kwargs`` as a dict.

    Raises:
        ValueError: ``{source}: unknown key '{key}.{name}' (not a FlowNavEnv argument)`` for an unknown name,
            ``{source}: key '{key}.{name}': {what is wrong}`` for a value its rule (or the estimator, for
            ``estimator_kwargs``) rejects.
    """
    for name in env_kwargs:
        if name not in ENV_ARGUMENTS:
            raise ValueError(f"{source}: unknown key '{key}.{name}' (not a FlowNavEnv argument)")
    arguments = dict(env_kwargs)
    try:
        check_render_mode(arguments.pop("render_mode", None))
        settings_with(None, arguments)
    except ValueError as error:
        # Every rule's message starts with the name it checked (``histogram_sectors[1]``, an estimator
        # argument), which is the key to point at.
        bad = str(error).split(" ", 1)[0]
        raise ValueError(f"{source}: key '{key}.{bad}': {error}") from error
    return dict(env_kwargs)
