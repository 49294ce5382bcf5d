"""What ``suite.md`` says of the noisy tiers' velocity reading: the frozen reading in words, and the agents flown
at suite v1's harsher reading beside it on suite v2's check layouts (the sensitivity flights of
:mod:`agents.evaluation.suite_check_flights`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from agents.evaluation.suite_check_flights import SensitivityRow, sensitivity_rows
from agents.evaluation.suite_checks import frozen_physics


@dataclass(frozen=True)
class VelocityReading:
    """What ``suite.md`` says of the noisy tiers' velocity reading: the frozen reading and the harsher one in words,
    the sensitivity rows of the agents flown at both (``suite_check_flights.sensitivity_rows``), and the page they are
    from."""

    frozen: str
    harsher: str
    rows: tuple[SensitivityRow, ...]
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
