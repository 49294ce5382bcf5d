"""The error report of a sweep flown on suite tiers (suite v2's: its clean tier, and the hard tier's sensor
factors): each tier's tolerance table and dose-response fits, each cell's failure paired by layout against the
tier's clean cell, how far sideways each cell's successes went, and each tolerance beside an earlier sweep's.

A sweep's cells all fly the same layouts, and a learned agent flies layout i with the same training seed in every
cell, so a cell and the clean cell are paired layout by layout.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from agents.analysis.episode_record import EpisodeRow
from agents.analysis.paired import compare
from agents.analysis.tolerance_rows import ToleranceRow
from agents.evaluation.lane import recorded_extent
from agents.studies.error_analysis import best_learned_flow_agent
from flownav_env.tiers import tier_of_env_id, tier_value

# A cell counts as flown in full at this many layouts: what the v2 sweep's configs fly, and the fewest that its
# paired differences from clean are read at.
FULL_CELL_LAYOUTS = 100
# The label an earlier sweep's and this one's best learned flow agents share in the tolerance comparison.
BEST_LEARNED = "best learned flow agent"


@dataclass(frozen=True)
class PairedCell:
    """One agent's cell against its clean cell on the layouts both flew: failure difference (cell − clean) with
    its 95 % bootstrap interval, and how many layouts were paired."""

    agent: str
    factor: str
    level: float
    difference: float
    low: float
    high: float
    layouts: int


@dataclass(frozen=True)
class SidewaysCell:
    """How far sideways one agent's successes in one cell went: how many succeeded with a recorded extent, how
    many of those went past the capsule field's edge, and the widest."""

    agent: str
    factor: str
    level: float
    successes: int
    past_field: int
    widest: float


@dataclass(frozen=True)
class ToleranceShift:
    """One agent, factor and side in an earlier sweep and in this one: the level tolerated up to and the first that
    breaks (None: none flown does), and which way the breaking point moved."""

    agent: str
    factor: str
    side: str
    before_tolerated: float | None
    now_tolerated: float | None
    before_breaks: float | None
    now_breaks: float | None
    moved: str


def tier_name(env_id: str | None) -> str:
    """The suite tier whose id is ``env_id``, or the id itself where it is no tier's (an older task; "" for a row
    from before env ids were recorded)."""
    found = tier_of_env_id(env_id or "")
    return (env_id or "") if found is None else found[1].name


def rows_by_tier(rows: Sequence[EpisodeRow]) -> dict[str, list[EpisodeRow]]:
    """``rows`` grouped by the tier they flew (:func:`tier_name` of their env id), in the order first met."""
    grouped: dict[str, list[EpisodeRow]] = {}
    for row in rows:
        grouped.setdefault(tier_name(row["env_id"]), []).append(row)
    return grouped


def tier_baseline(suite_rows: Sequence[EpisodeRow], env_id: str | None) -> list[EpisodeRow]:
    """The suite's episodes on ``env_id`` as clean cells (the suite keeps a tier in the factor column): the
    breaking points' reference for a sweep on that tier, over the suite's 300 layouts."""
    return [{**row, "factor": "clean", "level": 0.0} for row in suite_rows if row["env_id"] == env_id]


def _failures_by_layout(rows: Sequence[EpisodeRow]) -> dict[int, float]:
    return {int(row["seed"]): float(not row["success"]) for row in rows}


def paired_cells(rows: Sequence[EpisodeRow]) -> list[PairedCell]:
    """Every (agent, factor, level) cell of one tier's sweep against the agent's clean cell, paired by layout,
    in the rows' agent and cell order; cells with fewer than 2 layouts in common are left out."""
    cells: dict[tuple[str, str, float], list[EpisodeRow]] = {}
    for row in rows:
        cells.setdefault((row["agent"], row["factor"], float(row["level"])), []).append(row)
    result = []
    for (agent, factor, level), members in cells.items():
        clean = cells.get((agent, "clean", 0.0))
        if factor == "clean" or clean is None:
            continue
        mine, theirs = _failures_by_layout(members), _failures_by_layout(clean)
        shared = sorted(set(mine) & set(theirs))
        if len(shared) < 2:
            continue
        comparison = compare(
            agent,
            np.array([[mine[seed] for seed in shared]]),
            "clean",
            np.array([[theirs[seed] for seed in shared]]),
        )
        result.append(
            PairedCell(
                agent, factor, level, comparison.difference, comparison.low, comparison.high, len(shared)
            )
        )
    return result


def sideways_cells(rows: Sequence[EpisodeRow], tier: str, version: str) -> list[SidewaysCell]:
    """Per (agent, factor, level) cell of one tier's sweep, its successes' sideways extent against the capsule
    field's half-width on suite ``version``'s tier: a success past the edge passed capsules it never had to
    avoid. Cells none of whose successes recorded an extent are left out."""
    edge = float(tier_value(tier, "field_width", version)) / 2.0
    extents: dict[tuple[str, str, float], list[float]] = {}
    for row in rows:
        extent = recorded_extent(row)
        if row["success"] and extent is not None:
            extents.setdefault((row["agent"], row["factor"], float(row["level"])), []).append(extent)
    return [
        SidewaysCell(agent, factor, level, len(found), sum(x > edge for x in found), max(found))
        for (agent, factor, level), found in extents.items()
    ]


def _relabel_best(table: Sequence[ToleranceRow]) -> dict[tuple[str, str, str], ToleranceRow]:
    """A tolerance table keyed by (agent, factor, side), its best learned flow agent also under
    :data:`BEST_LEARNED`, so that two sweeps' best learned agents meet even where they are not the same one."""
    best = best_learned_flow_agent(table)
    keyed = {(r["agent"], r["factor"], r["side"]): r for r in table}
    keyed.update({(BEST_LEARNED, r["factor"], r["side"]): r for r in table if r["agent"] == best})
    return keyed


def _outward(level: float | None, levels: Sequence[float]) -> float:
    """How far out along a side's scan ``level`` lies: its place among ``levels``, which run outward from the
    neutral one (None, no level breaks: past the last)."""
    return math.inf if level is None else float(levels.index(level))


def tolerance_shifts(now: Sequence[ToleranceRow], before: Sequence[ToleranceRow]) -> list[ToleranceShift]:
    """Each (agent, factor, side) in both tolerance tables, with the earlier and current tolerated and breaking
    levels and where the breaking point moved: "earlier" (a level nearer the neutral one breaks now),
    "later", or "same" (the same level, or none flown in either). Only levels both sweeps flew are compared,
    so a level added later cannot move a breaking point by itself."""
    earlier, current = _relabel_best(before), _relabel_best(now)
    shifts = []
    for key in sorted(set(earlier) & set(current), key=lambda k: (k[0] != BEST_LEARNED, k)):
        old, new = earlier[key], current[key]
        common = [x for x in old["levels"] if x in new["levels"]]
        old_break = _first_breaking_among(old, common)
        new_break = _first_breaking_among(new, common)
        old_place, new_place = _outward(old_break, common), _outward(new_break, common)
        moved = "same" if old_place == new_place else "earlier" if new_place < old_place else "later"
        shifts.append(
            ToleranceShift(
                key[0] if key[0] == BEST_LEARNED else old["agent"],
                key[1],
                key[2],
                old["tolerated_level"],
                new["tolerated_level"],
                old_break,
                new_break,
                moved,
            )
        )
    return shifts


def _first_breaking_among(row: ToleranceRow, levels: Sequence[float]) -> float | None:
    """The row's breaking level if it is one of ``levels``, else None (it broke at a level the other sweep did
    not fly, or not at all)."""
    return row["breaking_level"] if row["breaking_level"] in levels else None


def cell_counts(rows: Sequence[EpisodeRow]) -> Mapping[str, int]:
    """The fewest and most episodes any (agent, factor, level) cell holds: ``{"fewest": n, "most": m}``."""
    counts: dict[tuple[str, str, float], int] = {}
    for row in rows:
        key = (row["agent"], row["factor"], float(row["level"]))
        counts[key] = counts.get(key, 0) + 1
    return {"fewest": min(counts.values(), default=0), "most": max(counts.values(), default=0)}
