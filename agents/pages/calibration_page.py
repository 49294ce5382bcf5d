"""Suite v2's calibration page (``results/suite_v2_calibration/calibration.md``), worded from the committed
check flights (:mod:`agents.evaluation.suite_check_flights`) by ``templates/suite_checks.md.j2``.

This module reads episodes and words them, nothing else: it imports only the analysis, the bottom layer's
template and seed helpers, the check flights' summaries and its template (an import-linter contract in
``pyproject.toml`` and ``tests/agents/pages/test_calibration_page.py`` keep it so: no MuJoCo, Gymnasium or env).
The physics the page states is handed in by its caller as :class:`FrozenPhysics`
(:func:`agents.evaluation.suite_checks.frozen_physics`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TypedDict

from agents.common.folders import write_text_atomically
from agents.common.jinja_reports import render
from agents.common.seeds import SUITE_V2_CHECK_SEED_START, SUITE_V2_SENSOR_READING_SEED_START
from agents.evaluation.suite_check_flights import (
    FEASIBLE_FAILURE,
    CheckRow,
    FrozenPhysics,
    SensitivityRow,
    check_rows,
    passing,
    sensitivity_rows,
)

PAGE = "calibration.md"


class TierText(TypedDict):
    """A frozen tier as the page states it: its name, registered id, why it is so and the settings it fixes."""

    name: str
    env_id: str
    why: str
    settings: dict[str, object]


class ReadingText(TypedDict):
    """A reading of the GNSS velocity specification: its key, its meaning and its per-axis σ in m/s."""

    name: str
    meaning: str
    sigma: float


@dataclass(frozen=True)
class CalibrationValues:
    """Every value ``templates/suite_checks.md.j2`` words: the frozen physics, the checks and their verdicts."""

    command: str
    tiers: list[TierText]
    checks: list[CheckRow]
    all_pass: bool
    all_flown: bool
    sensitivity: list[SensitivityRow]
    feasible_failure: float
    check_seed: int
    sensitivity_seed: int
    capsule_radius: float
    hull_radius: float
    free_path_s: float
    hard_speed: float
    hard_density: float
    free_path_m: float
    field_width: float
    lateral_bound: float
    reading: str
    velocity_sigma: float
    readings: list[ReadingText]
    tau: float
    taus: list[float]
    accuracy: float


def check_values(folder: Path, command: str, physics: FrozenPhysics) -> CalibrationValues:
    """Every value the calibration page words."""
    checks = check_rows(folder, physics.tiers)
    tiers = [
        TierText(name=spec.name, env_id=spec.env_id, why=spec.why, settings=dict(spec.settings))
        for spec in physics.tiers
    ]
    hard = physics.tier("hard").settings
    readings = physics.velocity_readings
    return CalibrationValues(
        command=command,
        tiers=tiers,
        checks=checks,
        all_pass=passing(checks),
        all_flown=all(row["layouts"] for row in checks),
        sensitivity=sensitivity_rows(folder, physics),
        feasible_failure=FEASIBLE_FAILURE,
        check_seed=SUITE_V2_CHECK_SEED_START,
        sensitivity_seed=SUITE_V2_SENSOR_READING_SEED_START,
        capsule_radius=physics.capsule_radius_m,
        hull_radius=physics.hull_radius_m,
        free_path_s=physics.hard_free_path_s,
        hard_speed=hard["forward_speed"],
        hard_density=hard["obstacle_density"],
        free_path_m=1.0 / (hard["obstacle_density"] * 2 * (physics.capsule_radius_m + physics.hull_radius_m)),
        field_width=hard["field_width"],
        lateral_bound=hard["lateral_bound"],
        reading=readings[physics.flight_stack_reading][0],
        velocity_sigma=readings[physics.flight_stack_reading][1],
        readings=[
            ReadingText(name=key, meaning=meaning, sigma=sigma) for key, (meaning, sigma) in readings.items()
        ],
        tau=physics.velocity_correlation_s,
        taus=list(physics.velocity_correlation_readings_s),
        accuracy=physics.velocity_accuracy_m_s,
    )


def write_page(folder: Path, command: str, physics: FrozenPhysics) -> Sequence[str]:
    """Write ``<folder>/calibration.md`` from the checks flown into ``folder``; returns its lines."""
    text = render("agents.pages", "suite_checks.md.j2", check_values(Path(folder), command, physics))
    write_text_atomically(Path(folder) / PAGE, text)
    return text.splitlines()
