"""The sweep's values that the benchmark's summary, the README's results block and the thesis's closed-loop
paragraph word: its size, where the thesis's error model and a noise floor first break the agents, what scale
and direct depth errors break, and whether the winner's weak side is the told rotation. Each claim is a list of
the agents it holds for, read off :func:`agents.studies.error_analysis.tolerance_table`'s rows; the tables
themselves are ``error_analysis.md``'s."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TypedDict

from agents.analysis.tolerance_rows import ToleranceRow
from agents.common.study_choices import choices
from agents.pages.wording import display_name
from agents.policies.base import base_agent_name
from agents.studies.benchmark_data import BenchmarkData, Rate

FLOW = "ppo_flow@all"
TOLD_ROTATION = ("rotation_error", "rotation_bias", "rotation_drift", "rotation_noise_deg")


def sweep_agents(data: BenchmarkData) -> list[str]:
    """The sweep's agents (pooled names) in the leaderboard's order."""
    order = [r["agent"] for r in data.leaderboard]
    rank = {
        name: order.index(base_agent_name(name)) if base_agent_name(name) in order else 99
        for name in {k[0] for k in data.cells}
    }
    return sorted(rank, key=rank.__getitem__)


def broken_agents(data: BenchmarkData, factor: str, level: float) -> tuple[list[str], list[str]]:
    """The agents that flew ``factor`` at ``level``, in the sweep's order, split into those it has broken by then
    (their first breaking level, scanning outward from the neutral level, lies at or before it) and the rest.

    Raises:
        ValueError: no agent flew ``factor`` at ``level``.
    """
    order = sweep_agents(data)
    rows = [r for r in data.tolerance if r["factor"] == factor and level in r["levels"]]
    if not rows:
        raise ValueError(f"no agent in the sweep flew {factor} at {level:g}")
    split: tuple[list[str], list[str]] = ([], [])
    for row in sorted(rows, key=lambda r: order.index(r["agent"])):
        levels, first = list(row["levels"]), row["breaking_level"]
        split[first is None or levels.index(first) > levels.index(level)].append(row["agent"])
    return split


class NamedRate(TypedDict):
    """An agent's display name and its failure in one sweep cell."""

    name: str
    rate: float


class BrokenBy(TypedDict):
    """A sweep level and the agents it has broken by then, and those it has not (:func:`broken_by`)."""

    level: float
    broken: list[NamedRate]
    unbroken: list[NamedRate]


def broken_by(data: BenchmarkData, factor: str, level: float) -> BrokenBy:
    """:func:`broken_agents` as the template words it: display names with their failure at ``level``."""
    named = [
        [NamedRate(name=display_name(a), rate=data.cells[(a, factor, float(level))].rate) for a in side]
        for side in broken_agents(data, factor, level)
    ]
    return BrokenBy(level=level, broken=named[0], unbroken=named[1])


def _levels(data: BenchmarkData, factor: str) -> list[float]:
    return sorted({key[2] for key in data.cells if key[1] == factor})


def _breaking(data: BenchmarkData, agent: str, factor: str, side: str = "above") -> float | None:
    row = data.tolerance_row(agent, factor, side)
    return None if row is None else row["breaking_level"]


def _first_breaking(rows: Sequence[ToleranceRow]) -> float | None:
    """The lowest breaking level among tolerance ``rows``; None where none of them breaks."""
    return min((r["breaking_level"] for r in rows if r["breaking_level"] is not None), default=None)


def _rotation_only(data: BenchmarkData) -> bool:
    """Whether the winner fails materially more than ``ppo_flow`` (pooled) in some sweep cell off the clean
    course, and every such cell is an error in the told rotation."""
    c = choices()
    winner = f"{c.winner}@all"
    worse = {
        key[1]
        for key, flow in data.cells.items()
        if key[0] == FLOW
        and key[1] != "clean"
        and (winner, *key[1:]) in data.cells
        and data.cells[(winner, *key[1:])].rate - flow.rate >= c.material
    }
    return bool(worse) and worse <= set(TOLD_ROTATION)


class ThesisRows(TypedDict):
    """The tolerance rows the thesis's comparison reads: ``ppo_flow``'s and ``bee_ttc``'s to relative rotation
    error, and ``ppo_flow``'s to rotation bias above and below (None where not flown)."""

    flow_rotation: ToleranceRow | None
    ttc_rotation: ToleranceRow | None
    flow_bias: list[ToleranceRow | None]


@dataclass(frozen=True)
class FindingValues:
    """Where the sweep's errors first break the agents (:func:`finding_values`): a level is None where none
    breaks."""

    rotation_first: float | None
    relative_first: float | None
    flow_relative: list[float | None]
    floor_low: BrokenBy
    floor_harsher: bool
    tb_low: BrokenBy
    scale_spares_rules: bool
    dn: BrokenBy
    rotation_only: bool
    rb_level: float
    thesis_rows: ThesisRows


def finding_values(data: BenchmarkData) -> FindingValues:
    """Where relative per-frame error (the thesis's model) first breaks any agent and ``ppo_flow``; who the
    lowest noise floor, translation bias and the depth noise that breaks ``ppo_flow`` (the most flown where none
    does) break; whether the floor breaks most agents, whether a scale error spares the centring rules, the
    rotation bias the winner breaks at (the farthest flown where it never does) and the thesis's rows.

    Raises:
        ValueError: the sweep has no rotation bias above its neutral level for the winner.
    """
    c = choices()
    relative = [r for r in data.tolerance if r["factor"] in ("rotation_error", "translation_error")]
    floor = broken_agents(data, "rotation_noise_deg", _levels(data, "rotation_noise_deg")[0])
    bias = _levels(data, "translation_bias")[0]
    bias_breaks = broken_agents(data, "translation_bias", bias)[0]
    noise = _breaking(data, FLOW, "depth_noise") or _levels(data, "depth_noise")[-1]
    rotation_bias = data.tolerance_row(c.winner, "rotation_bias")
    if rotation_bias is None:
        raise ValueError("the sweep has no rotation bias above its neutral level for the winner")
    return FindingValues(
        rotation_first=_first_breaking([r for r in relative if r["factor"] == "rotation_error"]),
        relative_first=_first_breaking(relative),
        flow_relative=[_breaking(data, FLOW, f) for f in ("rotation_error", "translation_error")],
        floor_low=broken_by(data, "rotation_noise_deg", _levels(data, "rotation_noise_deg")[0]),
        floor_harsher=len(floor[0]) >= len(floor[1]),
        tb_low=broken_by(data, "translation_bias", bias),
        scale_spares_rules=FLOW in bias_breaks and not set(c.centring_rules) & set(bias_breaks),
        dn=broken_by(data, "depth_noise", noise),
        rotation_only=_rotation_only(data),
        rb_level=rotation_bias["breaking_level"] or max(rotation_bias["levels"]),
        thesis_rows=ThesisRows(
            flow_rotation=data.tolerance_row(FLOW, "rotation_error"),
            ttc_rotation=data.tolerance_row("bee_ttc", "rotation_error"),
            flow_bias=[data.tolerance_row(FLOW, "rotation_bias", side) for side in ("above", "below")],
        ),
    )


@dataclass(frozen=True)
class SweepValues(FindingValues):
    """The sweep's size, a lookup of any of its cells, and its findings (:func:`sweep_values`)."""

    sweep_episodes: int
    per_cell: list[int]
    sweep_factor_count: int
    sweep_agent_count: int
    cell: Callable[[str, str, float], Rate]


def sweep_values(data: BenchmarkData) -> SweepValues:
    """The sweep's size and its findings (:func:`finding_values`)."""
    return SweepValues(
        sweep_episodes=len(data.sweep_rows),
        per_cell=sorted({cell.episodes for cell in data.cells.values()}),
        sweep_factor_count=len({key[1] for key in data.cells} - {"clean"}),
        sweep_agent_count=len(sweep_agents(data)),
        cell=data.cell,
        **vars(finding_values(data)),
    )
