"""FlowNavEnv's declared face: the Info table of its docstring lists exactly the keys ``reset`` and ``step``
return, and every sensor variable is a declared, typed attribute."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import SMALL

from flownav_env import FlowNavEnv
from flownav_env.env_arguments import SensorSetting, Setting
from flownav_env.settings import SENSOR_FIELDS


def _info_table() -> dict[str, str]:
    """The Info table's rows: key → its "Returned by" cell."""
    doc = FlowNavEnv.__doc__ or ""
    lines = doc[doc.index("## Info") :].splitlines()
    rows = [line.strip().strip("|").split("|") for line in lines if line.strip().startswith("| ``")]
    return {cells[0].strip().strip("`"): cells[1].strip() for cells in rows}


def _keys(returned_by: str, conditional: bool = True) -> set[str]:
    """The keys the table says ``returned_by`` ("reset" or "step") returns; those returned only "when ..."
    left out unless ``conditional``."""
    keys = set()
    for key, cell in _info_table().items():
        parts = [part.strip() for part in cell.split(",")]
        if returned_by in parts and (conditional or not any(part.startswith("when") for part in parts)):
            keys.add(key)
    return keys


def _infos(**settings: object) -> tuple[dict, dict]:
    env = FlowNavEnv(**SMALL, **settings)
    try:
        _, reset_info = env.reset(seed=0)
        for _ in range(4):
            _, _, _, _, step_info = env.step(np.zeros(3, np.float32))
    finally:
        env.close()
    return reset_info, step_info


def test_the_info_table_lists_exactly_the_keys_reset_and_step_return() -> None:
    reset_info, step_info = _infos()
    assert set(reset_info) == _keys("reset")
    assert set(step_info) == _keys("step")
    assert "position" in step_info and "min_clearance" in step_info  # what episode records read
    # Without true depths the conditional keys are absent, and only they.
    _, skipped = _infos(depth_error_info=False)
    assert set(skipped) == _keys("step", conditional=False) != _keys("step")


def test_every_sensor_variable_is_a_declared_attribute() -> None:
    declared = {name for name, value in vars(FlowNavEnv).items() if isinstance(value, SensorSetting)}
    assert declared == set(SENSOR_FIELDS)
    env = FlowNavEnv(**SMALL)
    try:
        env.brightness = 2.0  # assigning goes through set_sensor
        assert env.brightness == env.settings.brightness == 2.0
        with pytest.raises(ValueError, match="brightness"):
            env.brightness = 9.0
        assert env.forward_speed == env.settings.forward_speed and env.substeps == env.settings.substeps
    finally:
        env.close()


def test_an_attribute_must_name_a_setting() -> None:
    # Called as a class body would (Python 3.11 wraps the error in a RuntimeError there; 3.12 does not).
    class Broken:
        pass

    with pytest.raises(ValueError, match=r"Broken.speed reads no setting of EnvSettings"):
        Setting().__set_name__(Broken, "speed")
    with pytest.raises(ValueError, match=r"Broken.layout is no sensor setting; they are attitude_jitter_deg"):
        SensorSetting().__set_name__(Broken, "layout")
