"""The sweep's summary CSV (``sweep.csv``): one row per (agent, factor, level) cell, its rates with their
intervals (:func:`agents.analysis.statistics.summarise`)."""

from __future__ import annotations

import csv
from collections.abc import Sequence
from pathlib import Path

from agents.analysis.episode_record import EpisodeRow
from agents.analysis.statistics import CellSummary, summarise

SUMMARY_FIELDS = [
    "agent",
    "factor",
    "level",
    "episodes",
    "collisions",
    "collision_rate",
    "ci_low",
    "ci_high",
    "success_rate",
    "success_ci_low",
    "success_ci_high",
    "median_progress_m",
    "median_min_clearance_m",
    # Added after the first sweeps: appended, so readers of the columns above keep working.
    "out_of_bounds",
    "failure_rate",
    "failure_ci_low",
    "failure_ci_high",
]


def write_summary(rows: Sequence[EpisodeRow], path: Path) -> list[CellSummary]:
    table = summarise(rows)
    with path.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=SUMMARY_FIELDS)
        writer.writeheader()
        for row in table:
            writer.writerow({k: (round(v, 4) if isinstance(v, float) else v) for k, v in row.items()})
    return table
