"""The capsule-free lane beside every field: a tier's capsules stand within ``field_width / 2`` of the course
axis, while out of bounds starts only at ``lateral_bound``, so a strip free of capsules runs along each side. An
agent that drifts there instead of weaving would pass a tier without avoiding anything.

This counts, per agent and tier, the episodes whose drone went farther sideways than any capsule's surface
reaches (``field_width / 2 + obstacle_radius``), from flights that record ``max_abs_lateral_m``: one run per
agent on validation layouts from :data:`~agents.common.seeds.LANE_SEED_START`, flown by ``flownav evaluate``
into ``results/lane/<agent>_<tier>.csv``. Suite v1's own episodes predate that field.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from pathlib import Path
from typing import TypedDict

from agents.analysis.episode_record import EpisodeRow
from agents.analysis.records import read_records
from agents.evaluation.episode_tasks import TieredRow
from flownav_env.tiers import TIER_NAMES, TIERS_BY_VERSION, tier_value

# Where the lane flights lie, beside the suite's report.
LANE_DIR = "lane"
# The suite version whose open field left the lane (v2 closed it: its field reaches the bounds).
LANE_VERSION = "1"


def lane_edge(tier_name: str) -> float:
    """How far sideways (m) a drone of ``tier_name`` is past every capsule surface: the lane's inner edge."""
    width, radius = (
        float(tier_value(tier_name, key, LANE_VERSION)) for key in ("field_width", "obstacle_radius")
    )
    return width / 2.0 + radius


class LaneRow(TypedDict):
    """One (agent, tier) of :func:`lane_values`: the episodes that recorded their sideways extent, how many
    entered the lane, the farthest one (m), and the lane's edges (m)."""

    agent: str
    tier: str
    episodes: int
    entered: int
    widest: float
    edge: float
    bound: float


def recorded_extent(row: EpisodeRow) -> float | None:
    """How far sideways (m) the row's drone went; None where the row predates that record or lacks it."""
    extent = row.get("max_abs_lateral_m")
    return None if extent is None or math.isnan(extent) else float(extent)


def lane_values(folder: Path) -> list[LaneRow]:
    """Per (agent, tier) flown into ``folder``'s CSVs, in agent then tier order: the episodes that recorded
    their sideways extent, how many entered the lane, the farthest one (m), and the lane's edges (m)."""
    tiers_by_env = {spec.env_id: name for name, spec in TIERS_BY_VERSION[LANE_VERSION].items()}
    extents: dict[tuple[str, str], list[float]] = {}
    for path in sorted(Path(folder).glob("*.csv")):
        for row in read_records(path):
            extent = recorded_extent(row)
            if row["env_id"] in tiers_by_env and extent is not None:
                extents.setdefault((row["agent"], tiers_by_env[row["env_id"]]), []).append(extent)
    return [
        {
            "agent": agent,
            "tier": name,
            "episodes": len(found),
            "entered": sum(extent > lane_edge(name) for extent in found),
            "widest": max(found),
            "edge": lane_edge(name),
            "bound": float(tier_value(name, "lateral_bound", LANE_VERSION)),
        }
        for (agent, name), found in sorted(
            extents.items(), key=lambda item: (item[0][0], TIER_NAMES.index(item[0][1]))
        )
    ]


# How close to the field's edge (m) a success counts as flying along it: a drone there meets capsules from one
# side only, about half the field's density, a strip worth watching even where the field is closed.
NEAR_EDGE_M = 1.0


class SidewaysRow(TypedDict):
    """One tier of :func:`sideways_extent`: the successes that recorded how far sideways the drone went, how many
    of them came within :data:`NEAR_EDGE_M` of the capsule field's edge and how many went past it, the farthest
    (m), the field's edge and the lateral bound (m)."""

    tier: str
    successes: int
    near_edge: int
    past_field: int
    widest: float
    field_edge: float
    bound: float


def sideways_extent(rows: Iterable[TieredRow], version: str) -> list[SidewaysRow]:
    """Per tier of suite ``version`` that ``rows`` flew, in suite order, how far sideways its successes went
    against the capsule field's half-width: a success past the field's edge passed capsules it never had to
    avoid, which a closed field (suite v2) leaves no room for."""
    extents: dict[str, list[float]] = {}
    for row in rows:
        extent = recorded_extent(row)
        if row["success"] and extent is not None:
            extents.setdefault(row["tier"], []).append(extent)
    result: list[SidewaysRow] = []
    for name in sorted(extents, key=TIER_NAMES.index):
        edge = float(tier_value(name, "field_width", version)) / 2.0
        result.append(
            {
                "tier": name,
                "successes": len(extents[name]),
                "near_edge": sum(extent > edge - NEAR_EDGE_M for extent in extents[name]),
                "past_field": sum(extent > edge for extent in extents[name]),
                "widest": max(extents[name]),
                "field_edge": edge,
                "bound": float(tier_value(name, "lateral_bound", version)),
            }
        )
    return result
