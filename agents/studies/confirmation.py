"""Confirming the lever search's pick on validation layouts the search never saw (``flownav confirm``).

The lever search tried configurations one after another on the ablation layouts and stopped at the first whose
point estimates met the robustness conditions: a best-of-many pick. Here the pick (:data:`PICK`) and what it is compared with
(:data:`COMPARED`) fly the training seeds the search compared on :data:`CONFIRMATION_LAYOUTS` fresh validation layouts from
``CONFIRMATION_SEED_START``, clean and under each of :data:`CONDITIONS`. Every run flies every layout, so
comparisons are paired by layout; intervals come from a bootstrap that resamples training seeds (of each agent
apart) and layouts (once for all agents). Each agent's episodes go to ``<out>/<agent>.csv`` (resumable).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TypedDict, Unpack

import numpy as np

from agents.analysis.over_seeds import success_outcomes
from agents.analysis.paired import compare
from agents.analysis.records import read_records
from agents.analysis.statistics import runs_and_layouts_interval
from agents.analysis.validation_rows import (
    ConditionRate,
    ConfirmationResult,
    PairedDifference,
    Rise,
    SearchRecord,
)
from agents.common.folders import check_writable_folder, write_text_atomically
from agents.common.locations import POLICIES_DIR, RESULTS_DIR
from agents.common.seeds import CONFIRMATION_SEED_START
from agents.common.study_choices import BenchmarkChoices, choices
from agents.common.tables import today
from agents.evaluation.episode_tasks import EpisodeTask, record_label, rows_of
from agents.evaluation.runner import execute
from agents.pages.wording import render_report
from agents.policies import seeded_agent_name, trained_seeds
from agents.studies.benchmark_data import seed_failures

PICK = choices().winner
# Its own first stage (the pick is this run plus a gentler second stage) and the plain flow policy.
COMPARED = ("ppo_flow_course_approach", "ppo_flow")
# The pick's recipe, both stages and the same budget, trained on the true depths at the same tracked points
# (the true-depth comparison): the pick minus it is what optical flow costs this learned policy. Flown once its seeds are shipped.
TRUE_DEPTH_RECIPE = choices().truth_recipe
CONDITIONS: dict[str, dict[str, float]] = {
    "clean": {},
    "density 0.18": {"obstacle_density": 0.18},
    "speed 1.5 m/s": {"forward_speed": 1.5},
}
CONFIRMATION_LAYOUTS = 200
# The robustness condition: under each harder course, failure at most this much above the agent's own clean rate.
ALLOWED_RISE = choices().max_rise
# The training runs per agent the lever search compared (seeds 0-4): the confirmation flies the same runs on
# fresh layouts, so seeds shipped later (ppo_flow's 5-9) take no part in it.
SEARCH_RUNS = 5
# Any learned name loads the policy file it is given; runs of different agents live in different CSVs.
RUN_LABEL = "ppo_flow"


def agent_runs(agent: str, policies_dir: Path = POLICIES_DIR) -> dict[str, Path]:
    """The shipped training seeds of ``agent`` the search compared (its first :data:`SEARCH_RUNS`): run label
    (``ppo_flow@k``) → its policy file."""
    return {
        seeded_agent_name(RUN_LABEL, seed): Path(policies_dir) / agent / f"seed_{seed}.zip"
        for seed in trained_seeds(agent, policies_dir)[:SEARCH_RUNS]
    }


def confirmation_tasks(runs: Mapping[str, Path], layouts: int = CONFIRMATION_LAYOUTS) -> list[EpisodeTask]:
    """Every run on every layout under every condition, condition by condition and layout by layout."""
    seeds = range(CONFIRMATION_SEED_START, CONFIRMATION_SEED_START + layouts)
    tasks = []
    for settings in CONDITIONS.values():
        factor, level = record_label(settings)
        for seed in seeds:
            for name, policy in runs.items():
                tasks.append(
                    EpisodeTask(
                        name, factor, level, seed, env_kwargs=tuple(settings.items()), policy=str(policy)
                    )
                )
    return tasks


def outcome_matrices(
    out: Path, agents: Sequence[str], layouts: int, policies_dir: Path = POLICIES_DIR
) -> dict[str, dict[str, np.ndarray]]:
    """condition → agent → failures (runs, layouts), for the agents and conditions whose every run has flown
    every layout."""
    seeds = list(range(CONFIRMATION_SEED_START, CONFIRMATION_SEED_START + layouts))
    result: dict[str, dict[str, np.ndarray]] = {condition: {} for condition in CONDITIONS}
    for agent in agents:
        runs = agent_runs(agent, policies_dir)
        path = Path(out) / f"{agent}.csv"
        if not runs or not path.is_file():
            continue
        rows = rows_of(confirmation_tasks(runs, layouts), read_records(path))
        for condition, settings in CONDITIONS.items():
            factor, level = record_label(settings)
            mine = [r for r in rows if r["factor"] == factor and float(r["level"]) == level]
            try:
                result[condition][agent] = 1.0 - success_outcomes(mine, list(runs), seeds)
            except ValueError:
                continue
    return result


def flown_agents(policies_dir: Path = POLICIES_DIR) -> tuple[str, ...]:
    """The agents the confirmation flies: the pick, what it is compared with, and the pick's recipe on true
    depths once that has shipped training seeds."""
    shipped_truth = (TRUE_DEPTH_RECIPE,) if trained_seeds(TRUE_DEPTH_RECIPE, policies_dir) else ()
    return (PICK, *COMPARED, *shipped_truth)


def paired_difference(first: np.ndarray, second: np.ndarray) -> tuple[float, float, float]:
    """Failure of ``first`` minus ``second`` (both runs × the same layouts) with its 95 % interval, from the
    paired test (:func:`agents.analysis.paired.compare`: layouts drawn once for both, each one's training
    runs apart)."""
    found = compare("first", first, "second", second)
    return found.difference, found.low, found.high


def run_confirmation(
    out: Path,
    *,
    layouts: int = CONFIRMATION_LAYOUTS,
    workers: int = 2,
    report_only: bool = False,
    policies_dir: Path = POLICIES_DIR,
) -> ConfirmationResult:
    """Fly (unless ``report_only``) the pick and what it is compared with into ``out``, then compare: each
    agent's failure per condition, the pick minus each other agent, and each agent's rise over its clean rate.

    Raises:
        ValueError: a bad layout or worker count, or an unwritable ``out``.
    """
    if layouts < 1:
        raise ValueError(f"--layouts must be >= 1, got {layouts}")
    if workers < 1:
        raise ValueError(f"--workers must be >= 1, got {workers}")
    out = Path(out)
    check_writable_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    agents = flown_agents(policies_dir)
    if not report_only:
        for agent in agents:
            runs = agent_runs(agent, policies_dir)
            execute(
                confirmation_tasks(runs, layouts), out / f"{agent}.csv", workers=workers, description=agent
            )
    matrices = outcome_matrices(out, agents, layouts, policies_dir)
    rates, differences, rises = [], [], []
    for condition, found in matrices.items():
        for agent, matrix in found.items():
            low, high = runs_and_layouts_interval(matrix)
            rates.append(ConditionRate(condition, agent, matrix.shape[0], matrix.mean(), low, high))
            clean = matrices["clean"].get(agent)
            if condition != "clean" and clean is not None:
                rise, low, high = paired_difference(matrix, clean)
                rises.append(Rise(condition, agent, rise, low, high))
        if PICK in found:
            for other in (*COMPARED, TRUE_DEPTH_RECIPE):
                if other in found:
                    value, low, high = paired_difference(found[PICK], found[other])
                    differences.append(PairedDifference(condition, other, value, low, high))
    return ConfirmationResult(layouts, rates, differences, rises)


# Where the lever search's ablation kept each condition's runs, under results/ablation/.
SEARCH_FOLDERS = {"clean": ".", "density 0.18": "density_0.18", "speed 1.5 m/s": "speed_1.5"}
# Configs flown under the same conditions after the lever search ended, so not part of it: the teacher recipe.
FLOWN_AFTER_THE_SEARCH = ("ppo_flow_teacher",)


def search_record(ablation_dir: Path) -> SearchRecord:
    """What the lever search was, read from its committed episodes: the configurations flown under the two
    robustness conditions, the validation layouts they flew, and the pick minus its first stage there, paired by layout
    (:func:`paired_difference`), per condition."""
    tried: list[str] = []
    layouts: set[int] = set()
    for searched in sorted(Path(ablation_dir).glob("*_*/")):
        configs = (p for p in searched.iterdir() if p.is_dir() and p.name != "reference")
        for config in sorted(p for p in configs if p.name not in FLOWN_AFTER_THE_SEARCH):
            for csv_path in config.glob("seed_*.csv"):
                layouts.update(int(row["seed"]) for row in read_records(csv_path))
            if config.name not in tried:
                tried.append(config.name)
    differences: list[PairedDifference] = []
    for condition, folder in SEARCH_FOLDERS.items():
        pick = seed_failures(Path(ablation_dir) / folder / PICK)
        first_stage = seed_failures(Path(ablation_dir) / folder / COMPARED[0])
        if pick is None or first_stage is None or pick.shape[1] != first_stage.shape[1]:
            continue
        value, low, high = paired_difference(pick, first_stage)
        differences.append(PairedDifference(condition, COMPARED[0], value, low, high))
    return SearchRecord(tried, sorted(layouts), differences)


def flow_costs(result: ConfirmationResult) -> list[PairedDifference]:
    """Per condition, the pick minus its recipe on true depths: what flow costs it (positive: flow fails more);
    empty until the true-depth recipe has flown."""
    return [d for d in result.differences if d.other == TRUE_DEPTH_RECIPE]


@dataclass(frozen=True)
class ConfirmationValues:
    """Every value ``confirmation.md`` words (``templates/confirmation.md.j2``): the confirmation's comparison,
    the search as it happened, the benchmark's choices, the pick's first stage and the layouts' first seed."""

    result: ConfirmationResult
    search: SearchRecord
    c: BenchmarkChoices
    first_stage: str
    seed_start: int
    generated: str
    command: str


def report_lines(result: ConfirmationResult, search: SearchRecord, command: str) -> list[str]:
    """``confirmation.md``: the search as it happened, then the pick against what it is compared with on fresh
    layouts."""
    values = ConfirmationValues(
        result=result,
        search=search,
        c=choices(),
        first_stage=COMPARED[0],
        seed_start=CONFIRMATION_SEED_START,
        generated=today(),
        command=command,
    )
    return render_report("confirmation.md.j2", values).split("\n")[:-1]


class ConfirmationFlights(TypedDict, total=False):
    """The options of :func:`run_confirmation` that say how it flies."""

    layouts: int
    workers: int
    report_only: bool
    policies_dir: Path


def write_confirmation(out: Path, command: str, **flights: Unpack[ConfirmationFlights]) -> list[str]:
    """:func:`run_confirmation` (``flights`` its options) beside the committed search (``results/ablation``),
    and ``out/confirmation.md`` written; returns its lines."""
    lines = report_lines(run_confirmation(out, **flights), search_record(RESULTS_DIR / "ablation"), command)
    write_text_atomically(Path(out) / "confirmation.md", "\n".join(lines) + "\n")
    return lines
