"""The rows of the error analysis's tolerance table (:func:`agents.studies.error_analysis.tolerance_table`): per
agent, sensor factor and side of its neutral level, the clean failure rate and how far the factor goes before the
failure rate leaves the clean interval, doubles or breaks. Dictionaries, as the reports and the robustness CSV
read them by key."""

from __future__ import annotations

from typing import TypedDict


class CleanFields(TypedDict):
    """An agent's clean failure rate with its 95 % interval, over how many episodes, and where they come from."""

    clean_failure: float
    clean_low: float
    clean_high: float
    clean_episodes: int
    clean_source: str


class ToleranceScan(TypedDict):
    """One side of a factor scanned outward from its neutral level: the levels flown, the last tolerated one, the
    first that doubles the clean rate and the first that breaks (None: none does), and the worst level."""

    levels: list[float]
    tolerated_level: float | None
    doubling_level: float | None
    worst_level: float
    worst_failure: float
    worst_low: float
    breaks: bool
    breaking_level: float | None
    breaking_failure: float | None


class ToleranceRow(CleanFields, ToleranceScan):
    """A tolerance table row: the agent, factor and side, its clean fields and scan, and the thesis's verdict."""

    agent: str
    factor: str
    side: str
    thesis: str
