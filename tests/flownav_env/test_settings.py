"""flownav_env.settings: one declaration per setting (default, rule, meaning), the messages the rules raise,
the env's constructor and Arguments table made from it, and the pure checks of flownav_env.settings_check."""

from __future__ import annotations

import inspect
import math
import re
from dataclasses import fields

import numpy as np
import pytest

from flownav_env import FlowNavEnv
from flownav_env.env_arguments import setting_rows
from flownav_env.setting_rules import Range
from flownav_env.settings import (
    DEPTH_ERROR_FIELDS,
    ENV_ESTIMATOR_DEFAULTS,
    SENSOR_FIELDS,
    EnvSettings,
    SensorSettings,
)
from flownav_env.settings_check import check_setting, setting_range

# The sensor error models beside the thesis's variables: each one's range and a value outside it.
ERROR_MODELS = {
    "rotation_bias": ("[-0.9, 0.9]", 0.95),
    "translation_bias": ("[-0.9, 0.9]", -1.0),
    "rotation_drift": ("[0.0, 1.0]", -0.1),
    "translation_drift": ("[0.0, 1.0]", 1.5),
    "rotation_noise_deg": ("[0.0, 10.0]", 12.0),
    "translation_noise_m": ("[0.0, 0.5]", 0.6),
    "depth_noise": ("[0.0, 2.0]", 2.5),
    "depth_outliers": ("[0.0, 1.0]", 1.01),
    "depth_dropout": ("[0.0, 1.0]", -0.5),
}


@pytest.mark.parametrize(
    ("rule", "value", "message"),
    [
        (Range(0.0, 5.0), 7, "x must be in [0.0, 5.0], got 7"),
        (Range(0.0, 5.0), "7", "x must be a number in [0.0, 5.0], got '7'"),
        (Range(0.0, 5.0), True, "x must be a number in [0.0, 5.0], got True"),
        (Range(0.0, 5.0), math.inf, "x must be in [0.0, 5.0], got inf"),
        (Range(0.0, 5.0, low_open=True), 0.0, "x must be in (0.0, 5.0], got 0.0"),
        (Range(0.0, math.inf, high_open=True), -1.0, "x must be in [0.0, inf), got -1.0"),
        (Range(16, 1280, integer=True), 16.0, "x must be an integer in [16, 1280], got 16.0"),
        (Range(16, 1280, integer=True), 1281, "x must be an integer in [16, 1280], got 1281"),
    ],
)
def test_range_names_value_and_interval(rule: Range, value, message: str) -> None:
    with pytest.raises(ValueError) as error:
        rule.check("x", value)
    assert str(error.value) == message


def test_range_normalises_to_float_or_int() -> None:
    assert Range(0.0, 5.0).check("x", np.int64(3)) == 3.0 and isinstance(Range(0.0, 5.0).check("x", 3), float)
    assert type(Range(1, 32, integer=True).check("x", np.int32(4))) is int


def test_a_range_tied_to_another_setting_must_be_resolved_first() -> None:
    with pytest.raises(TypeError, match="depends on flight_height"):
        next(f.metadata["rule"] for f in fields(EnvSettings) if f.name == "max_height").check("max_height", 3)


def test_check_setting_and_setting_range() -> None:
    assert check_setting("forward_speed", 2) == 2.0
    assert check_setting("histogram_sectors", [2, 4]) == (2, 4)
    assert setting_range("camera_width").high == 1280
    # Tied ranges resolve against the other setting's default, or the value given.
    assert str(setting_range("max_height").interval) == "(1.0, 20.0]"
    assert setting_range("obstacle_height", obstacle_radius=0.25).low == 0.5
    with pytest.raises(ValueError, match=r"^max_height must be in \(2.0, 20.0\], got 1.5$"):
        check_setting("max_height", 1.5, flight_height=2.0)
    with pytest.raises(ValueError, match=r"^forward_speed must be in \[0.0, 5.0\], got 7$"):
        check_setting("forward_speed", 7)
    with pytest.raises(
        ValueError, match=r"^unknown setting 'speed'; known: attitude_jitter_deg, .*, layout, "
    ):
        check_setting("speed", 1.0)
    with pytest.raises(ValueError, match=r"^layout is not a numeric setting \(its rule is Choice\)$"):
        setting_range("layout")


def test_settings_normalise_and_derive() -> None:
    settings = EnvSettings(
        frame_rate=20, depth_bin_edges=np.array([0, 1, 4]), estimator_kwargs={"max_points": 9}
    )
    assert settings.frame_rate == 20.0 and settings.depth_bin_edges == (0.0, 1.0, 4.0)
    assert settings.substeps == round(1 / (20 * 0.004))
    assert settings.estimator_arguments() == {**ENV_ESTIMATOR_DEFAULTS, "max_points": 9}
    assert settings.sensor == SensorSettings()
    assert settings.layout_params().field_length == settings.field_length
    with pytest.raises(TypeError):
        settings.estimator_kwargs["max_points"] = 3  # stored read-only


def test_with_sensor_checks_names_and_values() -> None:
    settings = EnvSettings()
    assert settings.with_sensor(brightness=2).sensor == SensorSettings(brightness=2.0)
    with pytest.raises(
        ValueError, match=r"^not sensor settings: \['forward_speed'\]; allowed: attitude_jitter"
    ):
        settings.with_sensor(forward_speed=2.0)
    with pytest.raises(ValueError, match=r"^brightness must be in \[0.0, 4.0\], got 5$"):
        settings.with_sensor(brightness=5)
    with pytest.raises(ValueError, match=r"^rotation_error must be a number in \[0.0, 1.0\], got 'a'$"):
        SensorSettings(rotation_error="a")


def test_sensor_rules_are_the_env_rules() -> None:
    env_rules = {f.name: f.metadata["rule"] for f in fields(EnvSettings)}
    sensor_rules = {f.name: f.metadata["rule"] for f in fields(SensorSettings)}
    assert tuple(sensor_rules) == SENSOR_FIELDS
    assert all(sensor_rules[name] is env_rules[name] for name in SENSOR_FIELDS)


def test_the_env_constructor_lists_no_setting_by_hand() -> None:
    # EnvSettings is the one declaration; the env takes it whole, or any of its fields by keyword.
    parameters = inspect.signature(FlowNavEnv.__init__).parameters
    assert list(parameters) == ["self", "settings", "render_mode", "overrides"]
    assert parameters["overrides"].kind is inspect.Parameter.VAR_KEYWORD


def _arguments_table() -> dict[str, str]:
    """FlowNavEnv's Arguments table: each documented name and its row."""
    table = FlowNavEnv.__doc__[FlowNavEnv.__doc__.index("## Arguments") :]
    rows = {}
    for line in table.splitlines()[3:]:
        if not line.startswith("    |"):
            break
        for name in re.findall(r"``(\w+)``", line.split("|")[1]):
            rows[name] = line
    return rows


def test_the_arguments_table_is_made_from_the_fields() -> None:
    rows = _arguments_table()
    assert list(rows) == ["settings", *(f.name for f in fields(EnvSettings)), "render_mode"]
    assert "{setting_rows}" not in FlowNavEnv.__doc__ and setting_rows() in FlowNavEnv.__doc__
    for item in fields(EnvSettings):
        assert item.metadata["meaning"] and item.metadata["meaning"] in rows[item.name], item.name
        assert item.metadata["rule"].describe() in rows[item.name], item.name
    assert '| ``layout`` | ``"field"`` |' in rows["layout"] and "| (3, 5) |" in rows["histogram_sectors"]


def test_every_range_appears_in_the_arguments_table() -> None:
    rows = _arguments_table()
    for item in fields(EnvSettings):
        rule = item.metadata["rule"]
        if not isinstance(rule, Range):
            continue
        row = rows[item.name]
        if rule.low_from is not None:
            assert f"``{rule.low_from}``, {rule.high:g}]" in row, item.name
        elif math.isinf(rule.high):
            assert f"≥ {rule.low:g}" in row, item.name
        else:
            match = re.search(r"in ([\[(])(-?[\d.]+), (-?[\d.]+)([\])])", row)
            assert match, item.name
            opened, low, high, closed = match.groups()
            assert (opened == "(", float(low), float(high), closed == ")") == (
                rule.low_open,
                rule.low,
                rule.high,
                rule.high_open,
            ), item.name


@pytest.mark.parametrize("name", list(ERROR_MODELS))
def test_each_error_model_is_a_checked_neutral_sensor_setting(name: str) -> None:
    interval, bad = ERROR_MODELS[name]
    assert name in SENSOR_FIELDS and getattr(EnvSettings(), name) == 0.0
    for build in (EnvSettings, SensorSettings, lambda **value: check_setting(name, value[name])):
        with pytest.raises(ValueError) as error:
            build(**{name: bad})
        assert str(error.value) == f"{name} must be in {interval}, got {bad!r}"
    with pytest.raises(ValueError, match=rf"^{name} must be a number in "):
        EnvSettings().with_sensor(**{name: "0.1"})
    assert EnvSettings().with_sensor(**{name: 0.5}).sensor == SensorSettings(**{name: 0.5})


def test_depth_errors_are_on_only_when_one_is_set() -> None:
    assert not SensorSettings().depth_errors
    assert all(SensorSettings(**{name: 0.1}).depth_errors for name in DEPTH_ERROR_FIELDS)
    assert not SensorSettings(rotation_bias=0.5, rotation_noise_deg=1.0).depth_errors


def test_estimator_arguments_are_checked_by_value_when_the_settings_are_made() -> None:
    # Values too, not only names: a config's estimator_kwargs fail at the check, before any env is built.
    with pytest.raises(
        ValueError, match=r"^fast_threshold must be an integer with 1 <= fast_threshold <= 255"
    ):
        EnvSettings(estimator_kwargs={"fast_threshold": 0})
    with pytest.raises(ValueError, match=r"^estimator_kwargs has unknown keys \['wind'\]; allowed: method, "):
        EnvSettings(estimator_kwargs={"wind": 1})
    assert dict(EnvSettings(estimator_kwargs={"fast_threshold": 5}).estimator_kwargs) == {"fast_threshold": 5}


def test_settings_pickle_and_copy_for_worker_processes() -> None:
    # A whole EnvSettings is a FlowNavEnv keyword now, and keywords travel to vector-env workers.
    import copy
    import pickle

    settings = EnvSettings(estimator_kwargs={"fast_threshold": 5}, forward_speed=2.0)
    assert pickle.loads(pickle.dumps(settings)) == settings == copy.deepcopy(settings)
    assert pickle.loads(pickle.dumps(settings)).estimator_arguments() == {"fast_threshold": 5}
