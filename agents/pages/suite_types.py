"""What ``suite.md``'s template (``templates/suite.md.j2``) is given, typed so mypy checks it: the page's
values (:class:`SuiteValues`, computed by :func:`agents.pages.suite_page.suite_values`), each tier's
(:class:`SuiteTier`), and the rows its sections list."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, TypedDict

from agents.analysis.paired import Comparison
from agents.analysis.reflights import ReflightSummary
from agents.evaluation.lane import LaneRow, SidewaysRow
from agents.evaluation.suite_report import SuiteRow
from agents.evaluation.tier_bound import TierBound
from agents.pages.suite_findings import SuiteFindings
from agents.pages.velocity_reading import VelocityReading

if TYPE_CHECKING:  # typing has it from Python 3.11; annotations are not evaluated at run time
    from typing import NotRequired


class ShownRow(SuiteRow):
    """A suite row as a tier's table shows it: what the agent trained on, its name as a table cell (an included
    agent's name is the user's text) and, ranked, whether it is in the top group and its comparison with the
    best (None for the best itself); left out of the ranking, why."""

    trained_on: str
    shown: str
    in_top: NotRequired[bool]
    comparison: NotRequired[Comparison | None]
    why: NotRequired[str]


class SensorReading(TypedDict):
    """An agent flown at another reading of the noisy tier's velocity specification
    (:func:`~agents.pages.suite_page.reading_values`)."""

    agent: str
    reading: str
    noise_m: float
    layouts: int
    first_seed: int
    suite_failure: float
    failure: float
    comparison: Comparison


class RetiredTier(TypedDict):
    """A retired agent's failure rate on one tier, per training seed that flew every layout."""

    tier: str
    failures: list[float]


class RetiredAgent(TypedDict):
    """An agent retired from the suite (:func:`~agents.pages.suite_page.retired_values`): why, and its seeds'
    failures per tier."""

    agent: str
    why: str
    tiers: list[RetiredTier]


@dataclass(frozen=True)
class SuiteTier:
    """One tier of the page: its ranked rows (the best first), its provisional and reference rows (each by
    failure rate), its best agent, its top group as table cells, whether its best leaves headroom, and what the
    tier allows (None when not bounded)."""

    name: str
    env_id: str
    why: str
    ranked: list[ShownRow]
    provisional: list[ShownRow]
    references: list[ShownRow]
    best: ShownRow
    top_group: list[str]
    room: bool
    bound: TierBound | None


@dataclass(frozen=True)
class SuiteValues(SuiteFindings):
    """Every value ``suite.md`` words: where it comes from, its tiers in suite order, the statistics it ranks
    with, and its sections beside the tables (each empty when there is nothing to say), its findings beyond
    them among them."""

    suite_version: str
    current_version: str
    seed_start_name: str
    generated: str
    command: str
    machine: str
    reflights: list[ReflightSummary]
    velocity_reading: VelocityReading | None
    first_layout: int
    last_layout: int
    layouts: int
    tiers: list[SuiteTier]
    outcomes: list[str]
    headroom_failure: float
    min_seeds: int
    significance: float
    bootstrap_draws: int
    p_value_error: float
    holm_factor: int
    holm_p_value_error: float
    missing: list[str]
    readings: list[SensorReading]
    suite_noise_m: float
    suite_reading: str
    reading_dir: str
    recipe_reports: dict[str, str]
    camera_recipe_reports: dict[str, str]
    camera_reference: str
    camera_margin: float
    lanes: list[LaneRow]
    sideways: list[SidewaysRow]
    near_edge_m: float
    lane_dir: str
    lane_seed: int
    retired: list[RetiredAgent]
    not_flown: dict[str, str]
    trained_on: dict[str, str]
    included_files: list[tuple[str, str]]
    not_counted: list[tuple[str, str]]
    figure: str
