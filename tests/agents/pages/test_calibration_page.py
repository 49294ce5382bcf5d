"""The calibration page reads committed flights without the simulator: importing it loads no MuJoCo, Gymnasium
or env module (import-linter's contract in pyproject.toml checks the imports; this checks a real interpreter),
and the physics it states is what it is handed."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest
from helpers import flight_modules_loaded_by

from agents.evaluation.suite_check_flights import FrozenPhysics, TierFacts
from agents.evaluation.suite_checks import frozen_physics
from agents.pages.calibration_page import check_values


def test_importing_the_calibration_page_loads_no_simulator() -> None:
    assert flight_modules_loaded_by("agents.pages.calibration_page") == []


def test_the_page_states_the_physics_it_is_handed(tmp_path: Path) -> None:
    frozen = frozen_physics()
    hard = frozen.tier("hard")
    wider = replace(hard, settings={**hard.settings, "field_width": 20.0, "obstacle_density": 0.1})
    physics = replace(frozen, tiers=tuple(wider if t.name == "hard" else t for t in frozen.tiers))
    values = check_values(tmp_path, "cmd", physics)
    assert (values.field_width, values.hard_density) == (20.0, 0.1)
    radii = physics.capsule_radius_m + physics.hull_radius_m
    assert values.free_path_m == pytest.approx(1.0 / (0.1 * 2 * radii))
    assert [row["env_id"] for row in values.checks][::2] == [t.env_id for t in physics.tiers]
    assert not any(row["layouts"] for row in values.checks)  # nothing flown into an empty folder


def test_a_tier_the_physics_lacks_is_refused_by_name() -> None:
    physics = FrozenPhysics(
        (TierFacts("clean", "FlowNav-v1", "", {}),), 0.1, 0.1, 1.0, 0.05, {}, "3d_speed", 1.0, ()
    )
    with pytest.raises(ValueError, match=r"^no tier 'hard'; the tiers are clean$"):
        physics.tier("hard")
