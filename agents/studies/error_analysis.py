"""How estimation errors cause failures (``flownav sweep --analysis``): a tolerance table per agent and factor,
and one dose-response model per agent that pools every factor and level.

- **Tolerance.** Per agent and factor, on each side of the factor's neutral level: the largest level whose
  failure rate stays inside the clean interval, the first level at which the failure rate reaches twice the
  clean one (none when twice the clean rate would exceed 1), and the first level whose interval lies wholly
  above the clean one (it breaks). The clean rate is the 300-layout clean table's where the agent has one.
  Intervals are over training runs and layouts for a learned agent pooled over its seeds, Wilson otherwise.
- **Dose-response** (:mod:`agents.analysis.dose_response`): failure against each cell's measured depth quality.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence

from agents.analysis.episode_record import EpisodeRow, is_flow_agent
from agents.analysis.statistics import failure
from agents.analysis.tolerance_rows import CleanFields, ToleranceRow, ToleranceScan
from agents.evaluation.sweep_factors import COMPOSITE_NEUTRAL
from agents.policies.base import LEARNED_AGENTS, base_agent_name
from flownav_env.settings import EnvSettings
from flownav_env.settings_check import setting_range

# What the thesis concluded for each factor it varied (../shared/thesis-figures.md), for the tolerance table.
THESIS_VERDICTS = {
    "attitude_jitter_deg": "excessively inaccurate from 1.5°; acceptable at 0.5°",
    "forward_speed": "accurate at 0.05–0.15 m per frame; fewer matches beyond, little data below 0.02",
    "brightness": "accuracy falls from the 4th of six light levels",
    "rotation_error": "at 8 % the depths no longer give accurate information: a strong threat",
    "translation_error": "a band close to a direct 2–10 % variation",
}
NOT_TESTED = "not tested"


def neutral_level(factor: str) -> float:
    """The level at which ``factor`` does nothing: its env default (1 for brightness, the default speed...), or a
    composite factor's (:data:`~agents.evaluation.sweep_factors.COMPOSITE_NEUTRAL`; −inf where none does)."""
    if factor in COMPOSITE_NEUTRAL:
        return COMPOSITE_NEUTRAL[factor]
    fields = dataclasses.fields(EnvSettings)
    defaults = {item.name: item.default for item in fields if isinstance(item.default, int | float)}
    if factor not in defaults:
        raise ValueError(f"{factor!r} is not an env setting, so it has no neutral level")
    return float(defaults[factor])


BASELINE_SOURCE = "the 300-layout clean table"
SWEEP_CLEAN_SOURCE = "the sweep's clean cell"


def tolerance_table(rows: Sequence[EpisodeRow], baseline: Sequence[EpisodeRow] = ()) -> list[ToleranceRow]:
    """Per agent, factor and side of the neutral level: the clean failure rate [CI], the largest level still
    inside the clean interval, the first level at which the failure rate doubles, the first level at which it
    breaks (its interval lies wholly above the clean one), and the thesis's verdict.

    The clean rate is the agent's episodes in ``baseline`` (the leaderboard's clean layouts, pooled over
    training seeds like ``rows``) where it has any, else the sweep's own clean cell: a breaking point measured
    against a noisy 100-layout clean cell moves with that cell's luck.

    A level is tolerated while its failure rate stays at or below the clean interval's upper end (a level
    that fails less than clean is no harm); scanning outward from the neutral level, the tolerated level is
    the last one before the first level above it.
    """
    cells: dict[tuple[str, str, float], list[EpisodeRow]] = {}
    for row in rows:
        cells.setdefault((row["agent"], row["factor"], float(row["level"])), []).append(row)
    clean_rows = _clean_rows(cells, baseline)
    table = []
    for agent in sorted({key[0] for key in cells}):
        if agent not in clean_rows:
            continue
        clean, clean_low, clean_high, clean_episodes = failure(clean_rows[agent][0])
        clean_fields = CleanFields(
            clean_failure=clean,
            clean_low=clean_low,
            clean_high=clean_high,
            clean_episodes=clean_episodes,
            clean_source=clean_rows[agent][1],
        )
        for factor in sorted({key[1] for key in cells if key[0] == agent and key[1] != "clean"}):
            table += _factor_rows(cells, agent, factor, clean_fields)
    return table


def _factor_rows(
    cells: Mapping[tuple[str, str, float], list[EpisodeRow]],
    agent: str,
    factor: str,
    clean_fields: CleanFields,
) -> list[ToleranceRow]:
    """The tolerance rows of one agent and factor: one per side of the neutral level with levels flown."""
    neutral = neutral_level(factor)
    levels = sorted(level for (a, f, level) in cells if a == agent and f == factor)
    rows = []
    for side, chosen in (
        ("above", [x for x in levels if x > neutral]),
        ("below", [x for x in levels if x < neutral][::-1]),
    ):
        if chosen:
            scan = _scan_outward(chosen, [cells[(agent, factor, x)] for x in chosen], neutral, clean_fields)
            thesis = THESIS_VERDICTS.get(factor, NOT_TESTED)
            rows.append(
                ToleranceRow(agent=agent, factor=factor, side=side, **clean_fields, **scan, thesis=thesis)
            )
    return rows


def baseline_of_flown_runs(baseline: Sequence[EpisodeRow], flown: Sequence[EpisodeRow]) -> list[EpisodeRow]:
    """The ``baseline`` episodes (the clean table's, not yet pooled) of the runs ``flown`` holds, by their names
    (``ppo_flow@3``): a sweep cell's rise is over the clean rate of the training runs that flew it, and a
    learned agent may have shipped more seeds since, which join the clean table but not a committed sweep."""
    runs = {row["agent"] for row in flown}
    return [row for row in baseline if row["agent"] in runs]


def _clean_rows(
    cells: Mapping[tuple[str, str, float], list[EpisodeRow]], baseline: Sequence[EpisodeRow]
) -> dict[str, tuple[list[EpisodeRow], str]]:
    """Per agent, its clean episodes and where they come from: the baseline's where it has any, else the
    sweep's clean cell; agents with neither are absent."""
    clean_rows: dict[str, tuple[list[EpisodeRow], str]] = {}
    for row in baseline:
        if row["factor"] == "clean":
            clean_rows.setdefault(row["agent"], ([], BASELINE_SOURCE))[0].append(row)
    for (agent, factor, level), members in cells.items():
        if factor == "clean" and level == 0.0:
            clean_rows.setdefault(agent, (members, SWEEP_CLEAN_SOURCE))
    return clean_rows


def _scan_outward(
    levels: Sequence[float],
    cell_rows: Sequence[Sequence[EpisodeRow]],
    neutral: float,
    clean_fields: CleanFields,
) -> ToleranceScan:
    """One side of a factor, its ``levels`` in order outward from ``neutral`` with each level's episodes: the
    tolerated, doubling, worst and breaking levels (see :func:`tolerance_table`)."""
    clean, clean_high = clean_fields["clean_failure"], clean_fields["clean_high"]
    tolerated, doubled, broke, breaking = neutral, None, False, None
    rates = []
    for level, members in zip(levels, cell_rows, strict=True):
        rate, low, high, n = failure(members)
        rates.append((level, rate, low, high, n))
        if breaking is None and low > clean_high:
            breaking = (level, rate)
        if not broke and rate <= clean_high:
            tolerated = level
        else:
            broke = True
        if doubled is None and _doubles(rate, clean, clean_high):
            doubled = level
    worst = max(rates, key=lambda r: r[1])
    return ToleranceScan(
        levels=[r[0] for r in rates],
        # None: not even the first level is tolerated, on a factor where no level does nothing.
        tolerated_level=tolerated if math.isfinite(tolerated) else None,
        doubling_level=doubled,
        worst_level=worst[0],
        worst_failure=worst[1],
        worst_low=worst[2],
        breaks=worst[2] > clean_high,
        breaking_level=None if breaking is None else breaking[0],
        breaking_failure=None if breaking is None else breaking[1],
    )


def _doubles(rate: float, clean: float, clean_high: float) -> bool:
    """Whether ``rate`` is twice the clean one and outside its interval; never where twice clean exceeds 1."""
    return 2.0 * clean <= 1.0 and rate >= 2.0 * clean and rate > clean_high


def unbroken_kind(row: ToleranceRow) -> str:
    """Why no level flown breaks a tolerance row's agent: "end" (flown to the end of the setting's range),
    "easier" (no level fails more than clean: the direction makes the task easier) or "short" (the levels stop
    short of the range's end: more are needed)."""
    try:
        allowed = setting_range(row["factor"])
    except ValueError:
        allowed = None
    end = None if allowed is None else allowed.high if row["side"] == "above" else allowed.low
    if end is not None and math.isclose(row["levels"][-1], end):
        return "end"
    return "easier" if row["worst_failure"] <= row["clean_failure"] else "short"


def best_learned_flow_agent(table: Sequence[ToleranceRow]) -> str | None:
    """The learned agent on flow depths with the lowest clean failure rate among a tolerance table's."""
    clean = {
        r["agent"]: r["clean_failure"]
        for r in table
        if base_agent_name(r["agent"]) in LEARNED_AGENTS and is_flow_agent({"agent": r["agent"]})
    }
    return min(clean, key=lambda agent: (clean[agent], agent)) if clean else None
