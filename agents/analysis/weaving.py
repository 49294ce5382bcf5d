"""How much each agent weaves on the clean course, beside its depth error under a relative rotation error: a
relative error scales the told rotation, so its harm grows with how much the agent turns (a section of
``error_analysis.md``)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TypedDict

import numpy as np

from agents.analysis.episode_record import EpisodeRow

# Episodes that ended within this many metres of the start say nothing of how much the agent weaves.
MIN_PROGRESS_FOR_WEAVING_M = 2.0


class AgentWeaving(TypedDict):
    """How much an agent weaves on the clean course, and its median depth error per level of the factor."""

    agent: str
    weaving: float
    depth_error: dict[float, float]


def turning_and_rotation_error(
    rows: Sequence[EpisodeRow], factor: str = "rotation_error"
) -> list[AgentWeaving]:
    """Per agent: how much it weaves on the clean course, and its median depth error at each level of a
    relative rotation error.

    A relative error scales the told rotation, so its harm grows with how much the agent turns. Weaving is the
    median over clean episodes of path length / forward progress − 1 (episodes with at least
    :data:`MIN_PROGRESS_FOR_WEAVING_M` of progress). Empty when the rows lack path length and progress (files
    from before they were recorded) or the factor was not flown.
    """
    if not rows or any(r.get("path_length_m") is None or r.get("progress_m") is None for r in rows):
        return []
    table: list[AgentWeaving] = []
    for agent in sorted({r["agent"] for r in rows}):
        clean = _clean_weaving(rows, agent)
        swept = [r for r in rows if r["agent"] == agent and r["factor"] in ("clean", factor)]
        errors = _median_depth_error_by_level(swept)
        if not clean or len(errors) < 2:
            continue
        table.append({"agent": agent, "weaving": float(np.median(clean)), "depth_error": errors})
    return sorted(table, key=lambda r: r["weaving"])


def _level_of(row: EpisodeRow) -> float:
    """The row's level, 0 for the clean cell (whose level column says nothing of the swept factor)."""
    return 0.0 if row["factor"] == "clean" else float(row["level"])


def _clean_weaving(rows: Sequence[EpisodeRow], agent: str) -> list[float]:
    """Path length / forward progress − 1 of the agent's clean episodes that made enough progress."""
    return [
        float(r["path_length_m"]) / float(r["progress_m"]) - 1.0
        for r in rows
        if r["agent"] == agent
        and r["factor"] == "clean"
        and float(r["progress_m"]) >= MIN_PROGRESS_FOR_WEAVING_M
    ]


def _median_depth_error_by_level(rows: Sequence[EpisodeRow]) -> dict[float, float]:
    """Per level, in increasing order, the median of its rows' finite median depth errors."""
    levels = sorted({_level_of(r) for r in rows})
    return {level: _median_depth_error([r for r in rows if _level_of(r) == level]) for level in levels}


def _median_depth_error(rows: Sequence[EpisodeRow]) -> float:
    """The median of the rows' finite median depth errors; NaN where none is finite."""
    depth_errors = [
        float(r["median_depth_error"]) for r in rows if math.isfinite(float(r["median_depth_error"]))
    ]
    return float(np.median(depth_errors)) if depth_errors else math.nan
