"""What ``flow_gap.md``'s template (``templates/flow_gap.md.j2``) is given, typed so mypy checks it: the
benchmark's page values (:class:`~agents.reports.benchmark_report.BenchmarkPageValues`, whose prose the page
shares) and this report's own, gathered part by part as :func:`agents.reports.flow_gap_report.flow_gap_values`
computes them."""

from __future__ import annotations

from dataclasses import dataclass

from agents.analysis.family import FamilyCorrection
from agents.analysis.paired import Comparison
from agents.analysis.validation_rows import PairedDifference, Rise, SearchRecord
from agents.reports.benchmark_report import BenchmarkPageValues
from agents.studies.benchmark_data import Rate


@dataclass(frozen=True)
class PlainGapValues:
    """The plain recipe's flow and true-depth agents: their training steps, clean validation rates, gap per
    suite tier, and why either is left off the suite version the page reads."""

    plain_steps: list[int]
    plain_validation: list[Rate]
    plain_suite_table: str
    plain_not_flown: dict[str, str]


@dataclass(frozen=True)
class SelectionValues:
    """The lever search as it happened and what the fresh layouts say about its pick: the pick's rises over its
    clean rate, and its differences from its first stage and from ``ppo_flow``."""

    search: SearchRecord
    confirmation_layouts: int
    pick_rises: list[Rise]
    first_stage: str
    stages: dict[str, list[PairedDifference]]
    after_the_search: list[str]


@dataclass(frozen=True)
class StudentGapValues:
    """The planner's flow-only student against its true-depth twin per tier, the planner beside as ceiling."""

    student: str
    student_truth: str
    student_truth_seeds: int
    student_not_flown: dict[str, str]
    student_suite_table: str


@dataclass(frozen=True)
class FlowGapValues(StudentGapValues, SelectionValues, PlainGapValues, BenchmarkPageValues):
    """Every value ``flow_gap.md`` words: the benchmark's page values, its parts' above, and the pick's gap
    against its recipe on true depths (on fresh validation layouts and on the suite), every gap of the page
    corrected as one family."""

    gap_family: FamilyCorrection
    truth_seeds: dict[str, int]
    seeds_wanted: int
    true_depth_stages: list[str]
    truth_confirmation_table: str
    truth_confirmation: list[tuple[str, Comparison]]
    truth_suite_table: str
    suite_version: str
    confirmation_layouts_wanted: int
