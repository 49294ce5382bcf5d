"""Suite v2's calibration page: the tiers' physics and sensor as frozen in code, and the only flights made before
the freeze, the privileged references' feasibility checks on validation layouts (``results/suite_v2_calibration/``).

Nothing here chooses a setting: the tiers are fixed in :mod:`flownav_env.tiers` from stated physics, and a tier
passes its check when each reference fails at most
:data:`~agents.evaluation.calibration_page.FEASIBLE_FAILURE` of the checked layouts. The flights are
``flownav evaluate --agent AGENT --env-id ENV --episodes N --seed-start SUITE_V2_CHECK_SEED_START --out
results/suite_v2_calibration/AGENT_ENV.csv``; the noisy tier at other readings of the velocity specification
(the sensitivity table) lies in ``sensitivity/AGENT_ENV_READING_TAU.csv`` beside them.

This module reads the frozen physics from the env package (:func:`frozen_physics`); the page itself, which
reads only the committed flights, is :mod:`agents.evaluation.calibration_page`. What ``suite.md`` says of the
noisy tiers' velocity reading, from the same sensitivity flights, is :func:`velocity_reading_values`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from agents.evaluation.calibration_page import FrozenPhysics, TierFacts, sensitivity_rows, write_page
from flownav_env import sensor_specs
from flownav_env.tiers import CAPSULE_RADIUS_M, HARD_FREE_PATH_S, HULL_RADIUS_M, TIER_NAMES, tier

CHECKED_VERSION = "2"


def frozen_physics(version: str = CHECKED_VERSION) -> FrozenPhysics:
    """Suite ``version``'s tiers and the sensor's velocity readings, as :mod:`flownav_env` freezes them."""
    tiers = tuple(
        TierFacts(name, spec.env_id, spec.why, spec.settings)
        for name in TIER_NAMES
        for spec in (tier(name, version),)
    )
    return FrozenPhysics(
        tiers=tiers,
        capsule_radius_m=CAPSULE_RADIUS_M,
        hull_radius_m=HULL_RADIUS_M,
        hard_free_path_s=HARD_FREE_PATH_S,
        velocity_accuracy_m_s=sensor_specs.VELOCITY_ACCURACY_M_S,
        velocity_readings=dict(sensor_specs.VELOCITY_READINGS),
        flight_stack_reading=sensor_specs.FLIGHT_STACK_READING,
        velocity_correlation_s=sensor_specs.VELOCITY_CORRELATION_S,
        velocity_correlation_readings_s=tuple(sensor_specs.VELOCITY_CORRELATION_READINGS_S),
    )


def write_checks(folder: Path, command: str) -> Sequence[str]:
    """Write ``<folder>/calibration.md`` from the checks flown into ``folder``; returns its lines."""
    return write_page(folder, command, frozen_physics())


@dataclass(frozen=True)
class VelocityReading:
    """What ``suite.md`` says of the noisy tiers' velocity reading: the frozen reading and the harsher one in words,
    the sensitivity rows of the agents flown at both (``calibration_page.sensitivity_rows``), and the page they are
    from."""

    frozen: str
    harsher: str
    rows: tuple[Mapping[str, object], ...]
    page: str


# Where suite v2's calibration flights lie beside the suite's episodes, the sensitivity to the velocity reading
# among them; the reading the noisy tiers would have had at suite v1's harsher choice.
CALIBRATION_DIRS = {"2": "suite_v2_calibration"}
HARSHER_READING = ("per_axis", 1.0)


def velocity_reading_values(out: Path, version: str) -> VelocityReading | None:
    """What ``suite.md`` says of the noisy tiers' velocity reading: the frozen reading in words, and each agent
    flown at suite v1's per-axis reading beside the frozen one on the same validation layouts (None where this
    version has no calibration flights beside it)."""
    folder = Path(out) / CALIBRATION_DIRS.get(version, "")
    if version not in CALIBRATION_DIRS or not folder.is_dir():
        return None
    physics = frozen_physics(version)
    harsher_words = physics.velocity_readings[HARSHER_READING[0]][0]
    rows = tuple(
        row
        for row in sensitivity_rows(folder, physics)
        if row["reading"] == harsher_words and row["tau"] == HARSHER_READING[1]
    )
    return VelocityReading(
        frozen=physics.velocity_readings[physics.flight_stack_reading][0],
        harsher=harsher_words,
        rows=rows,
        page=f"{CALIBRATION_DIRS[version]}/calibration.md",
    )
