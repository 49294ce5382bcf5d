"""The rows of the comparisons flown on validation layouts (``flownav ablation``, ``flownav confirm``), as their
reports read them: a config's failure over its runs, a rate per condition, a paired difference, a rise."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from agents.analysis.paired import Comparison


@dataclass(frozen=True)
class AblationRow:
    """A config's (or a reactive reference agent's) row of ``ablation.md``: failure over runs × layouts with its
    interval (None for a config's single seed), its outcome rates, each seed's failure (None for a reference),
    the (runs, layouts) failures it pairs with another row by, and that pairing against the first row."""

    config: str
    seeds: int | None
    episodes: int
    failure: float
    failure_low: float | None
    failure_high: float | None
    success: float
    collision: float
    out_of_bounds: float
    per_seed: list[tuple[int, float]] | None
    failures: np.ndarray = field(compare=False)
    versus_first: Comparison | None = None
    # How a config's runs were trained, from their records: the distinct commands, and each seed's minutes.
    commands: tuple[str, ...] = ()
    minutes_per_seed: tuple[tuple[int, float], ...] = ()


@dataclass(frozen=True)
class ConditionRate:
    """An agent's failure under a condition over its runs × layouts, with its 95 % interval."""

    condition: str
    agent: str
    runs: int
    failure: float
    low: float
    high: float


@dataclass(frozen=True)
class PairedDifference:
    """Under a condition, the pick's failure minus ``other``'s, paired by layout, with its 95 % interval."""

    condition: str
    other: str
    difference: float
    low: float
    high: float


@dataclass(frozen=True)
class Rise:
    """An agent's failure under a condition minus its own clean failure, paired by layout, with its interval."""

    condition: str
    agent: str
    rise: float
    low: float
    high: float


@dataclass(frozen=True)
class ConfirmationResult:
    """The confirmation on fresh validation layouts: every agent's rate per condition, the pick minus each
    other agent, and each agent's rise over its clean rate."""

    layouts: int
    rates: list[ConditionRate]
    differences: list[PairedDifference]
    rises: list[Rise]


@dataclass(frozen=True)
class SearchRecord:
    """What the lever search was: the configurations it flew, their validation layouts, and the pick minus its
    first stage per condition."""

    configs: list[str]
    layouts: list[int]
    differences: list[PairedDifference]
