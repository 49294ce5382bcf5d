"""The suite's ranking per tier: each agent's failures as a (runs, layouts) matrix, and the paired tests that
decide each tier's best agent and top group (:func:`agents.analysis.paired.rank_tier`). ``suite.md`` words it
(:mod:`agents.pages.suite_page`); the benchmark reads each tier's top group from it.

Privileged agents are listed apart as references; learned agents with fewer training seeds than
:data:`~agents.analysis.paired.MIN_RANKED_SEEDS` are provisional. Neither is ranked, named best, or decides a
tier's headroom.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from agents.analysis.over_seeds import episode_outcomes
from agents.analysis.paired import TierRanking, rank_tier
from agents.evaluation.episode_tasks import TieredRow
from agents.evaluation.suite_report import SuiteRow
from agents.policies import is_learned


def tier_failures(
    rows: Sequence[TieredRow],
    runs: Mapping[str, Sequence[str]],
    tier_name: str,
    layouts: Sequence[int],
) -> dict[str, np.ndarray]:
    """Each agent's failures on ``tier_name`` as a (runs, layouts) matrix, for the agents that flew every
    layout with every run; ``rows`` are suite episode rows with their ``tier``
    (:func:`~agents.evaluation.episode_tasks.with_tier`)."""
    mine = [row for row in rows if row["tier"] == tier_name]
    failures = {}
    for agent, names in runs.items():
        try:
            failures[agent] = episode_outcomes(mine, names, layouts, "failure")
        except ValueError:
            continue  # not flown in full: the report lists it as not yet flown
    return failures


def rank_suite(
    table: Sequence[SuiteRow], failures: Mapping[str, Mapping[str, np.ndarray]], seed: int = 0
) -> dict[str, TierRanking]:
    """Each tier's :class:`~agents.analysis.paired.TierRanking` of the agents in its rows, its bootstrap drawn
    from ``seed``; a tier with no rankable agent flown (privileged or provisional agents only) has none."""
    rankings = {}
    for name, matrices in failures.items():
        privileged = [row["agent"] for row in table if row["tier"] == name and row["privileged"]]
        learned = [agent for agent in matrices if _is_shipped_learned(agent)]
        try:
            rankings[name] = rank_tier(matrices, privileged=privileged, learned=learned, seed=seed)
        except ValueError:
            continue  # nothing rankable flown on this tier (say a reference flown on its own): no ranking
    return rankings


def _is_shipped_learned(agent: str) -> bool:
    """Whether ``agent`` is one of FlowNav's learned agents; an included agent's shown name (``my rule``) is not."""
    try:
        return is_learned(agent)
    except ValueError:
        return False
