"""The sections of a suite page beyond its tables, computed once for ``suite.md`` and for the page with included
agents (``suite_with_included.md``), so that both pages word the same findings from the same values: what each
tier allows, the learning gain, the chain from the map to flow, how far sideways the successes went, the
re-flights, the noisy tiers' velocity reading, the logged choices behind each agent, and the flights and reports kept beside the suite."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from agents.analysis.decision_rows import DECISION_CSV, AgentDecision, read_decision_rows
from agents.analysis.paired import TierRanking
from agents.analysis.reflights import REFLIGHT_CSV, ReflightSummary, read_reflights, summarise_reflights
from agents.evaluation.episode_tasks import TieredRow
from agents.evaluation.lane import SidewaysRow, sideways_extent
from agents.evaluation.learning_gain import LearningGain, learning_gains
from agents.evaluation.reference_chain import ChainLink, reference_chain
from agents.evaluation.suite import EPISODES_CSV
from agents.evaluation.tier_bound import TierBound, suite_bounds
from agents.pages.suite_page import BesideSuite, beside_suite
from agents.pages.velocity_reading import VelocityReading, velocity_reading_values


class PageSections(BesideSuite):
    """What :func:`page_sections` gives, as :func:`~agents.pages.suite_page.suite_values` takes it: what is
    kept beside the suite, and what its failure matrices and episodes give."""

    bounds: dict[str, TierBound]
    gains: list[LearningGain]
    chains: dict[str, list[ChainLink]]
    sideways: list[SidewaysRow]
    reflights: list[ReflightSummary]
    velocity_reading: VelocityReading | None
    decisions: dict[str, list[AgentDecision]]


def page_sections(
    folder: Path,
    rows: Sequence[TieredRow],
    failures: Mapping[str, Mapping[str, np.ndarray]],
    rankings: Mapping[str, TierRanking],
    seeds: Sequence[int],
    version: str,
) -> PageSections:
    """The sections of suite ``version``'s page from each tier's failure matrices (tier → agent → (runs,
    layouts) on ``seeds``) and rankings, the episodes ``rows`` (their sideways extents), and the flights and
    reports kept in the suite's ``folder``."""
    tier_names = [name for name in failures if failures[name]]
    bests = {name: ranking.best for name, ranking in rankings.items()}
    return {
        "bounds": dict(suite_bounds(failures, bests, seeds, version)),
        "gains": learning_gains(failures, rankings),
        "chains": {name: reference_chain(failures[name]) for name in tier_names},
        "sideways": sideways_extent(rows, version),
        "reflights": summarise_reflights(read_reflights(Path(folder) / REFLIGHT_CSV)),
        "velocity_reading": velocity_reading_values(Path(folder), version),
        "decisions": read_decision_rows(Path(folder) / DECISION_CSV),
        **beside_suite(Path(folder), tier_names, Path(folder) / EPISODES_CSV, seeds),
    }
