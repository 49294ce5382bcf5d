"""What the suite's tier calibration (:mod:`agents.studies.tier_calibration`) found, as ``calibration.md`` reads it:
a failure rate per (condition, agent), each tier's cells, and the result of every stage flown (a dictionary:
the report merges it into its template's values)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TypedDict


@dataclass(frozen=True)
class CalibrationCell:
    """One agent's failure rate under one condition (a candidate course, a tier, a pilot sensor) with its Wilson
    95 % interval: each agent is one run here."""

    factor: str
    agent: str
    failure_rate: float
    failure_low: float
    failure_high: float
    episodes: int


class CalibratedTier(TypedDict):
    """A tier's cells, best agent first, its best agent, and (told apart, compared) agent pairs."""

    rows: list[CalibrationCell]
    best: CalibrationCell
    separated: tuple[int, int]


class CalibrationResult(TypedDict):
    """Every stage flown: the pilot's cells and the settings each pilot factor flew with (canonical JSON), the
    layouts, the candidate courses' cells, the chosen course (None: none lands in the target) and whether it is
    the frozen one, each course's best agent, and each tier."""

    pilot: list[CalibrationCell]
    pilot_settings: dict[str, str]
    layouts: int
    table: list[CalibrationCell]
    chosen: dict[str, float] | None
    frozen_matches: bool
    best_per_course: dict[str, CalibrationCell]
    tiers: dict[str, CalibratedTier]
