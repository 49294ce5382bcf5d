"""How suite v1's tiers were chosen, on validation layouts only (``flownav calibrate-tiers``). Suite v2 chose
none of its tiers this way: they are fixed from physics (:mod:`flownav_env.tiers`), so this study is v1's
history and reads v1's tiers (the config's ``calibrated_version``). Its choices are
``configs/studies/tier_calibration.yaml`` (:data:`STUDY`).

1. **Hard course.** Every candidate course of the config (forward speed × obstacle density) is flown by the
   :data:`COURSE_AGENTS` on the config's ``layouts`` validation layouts from ``TIER_CALIBRATION_SEED_START``.
   The pick is the candidate whose best agent's failure rate lies in the config's ``target_failure`` and
   nearest its middle (ties: the slower, then the sparser course).
2. **Every tier but clean as registered** (``flownav_env.tiers``, with the frozen hard course) is flown by every
   agent on the same layouts, to show the best agent of each and how many pairs of agents a paired test tells apart.

The realistic sensor is not calibrated: its magnitudes are datasheet values (:mod:`flownav_env.tiers`).
A learned agent flies its shipped training seeds in turn over the layouts (one run), which is enough to rank.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TypedDict, Unpack

import numpy as np

from agents.analysis.episode_record import EpisodeRow
from agents.analysis.paired import compare
from agents.analysis.records import read_records
from agents.analysis.statistics import failure
from agents.analysis.tier_calibration_rows import CalibratedTier, CalibrationCell, CalibrationResult
from agents.common.folders import check_writable_folder, write_text_atomically
from agents.common.seeds import SENSOR_PILOT_SEED_START, TIER_CALIBRATION_SEED_START
from agents.common.tables import today
from agents.evaluation.episode_tasks import EpisodeTask, canonical_json, rows_of
from agents.evaluation.runner import execute
from agents.evaluation.suite_report import HEADROOM_FAILURE
from agents.pages.wording import render_report
from agents.policies import runs_to_fly
from agents.policies.base import base_agent_name
from agents.studies.study_configs import tier_calibration_config
from flownav_env.tiers import HARD_COURSE, TIER_NAMES, Tier
from flownav_env.tiers import tier as tier_of_version

# The study's choices (configs/studies/tier_calibration.yaml says why each); the agents' names are read from it.
STUDY = tier_calibration_config()
COURSE_AGENTS = tuple(STUDY.course_agents)
TIER_AGENTS = tuple(STUDY.tier_agents)
STAGES = ("course", "tiers")


def tier(name: str) -> Tier:
    """The tier ``name`` of the calibrated version."""
    return tier_of_version(name, STUDY.calibrated_version)


# The clean tier is today's defaults, flown on validation layouts many times already (results/ablation/).
CALIBRATED_TIERS = tuple(name for name in TIER_NAMES if name != "clean")
EPISODES_CSV = "calibration_episodes.csv"
# Versions of the realistic sensor tried before it was frozen, flown by hand (the note in calibration.md).
PILOT_CSV = "sensor_pilot_episodes.csv"


def course_label(course: Mapping[str, float]) -> str:
    """``forward_speed=2.0,obstacle_density=0.18``: the factor a candidate's records carry."""
    return ",".join(f"{key}={value}" for key, value in sorted(course.items()))


def tier_label(name: str) -> str:
    """The factor a frozen tier's calibration records carry: its name and settings, so that a tier re-frozen
    with other settings is flown again rather than mixed with the old episodes."""
    return f"tier:{name}[{course_label(tier(name).settings)}]"


def calibration_tasks(layouts: int = STUDY.layouts, stages: Sequence[str] = STAGES) -> list[EpisodeTask]:
    """Stage 1, ``course`` (every candidate course × course agent), then stage 2, ``tiers`` (every tier × tier
    agent), layout by layout within each. Stage 2 flies the tiers as frozen, so it runs after the pick."""
    seeds = range(TIER_CALIBRATION_SEED_START, TIER_CALIBRATION_SEED_START + layouts)
    runs = {agent: runs_to_fly(agent)[0][: STUDY.runs] for agent in TIER_AGENTS}

    def run_on(agent: str, index: int) -> str:
        return runs[agent][index % len(runs[agent])]  # a learned agent: its training seeds in turn

    tasks = [
        EpisodeTask(
            run_on(agent, i), course_label(course), 0.0, seed, env_kwargs=tuple(sorted(course.items()))
        )
        for course in (STUDY.courses if "course" in stages else ())
        for i, seed in enumerate(seeds)
        for agent in COURSE_AGENTS
    ]
    for name in CALIBRATED_TIERS if "tiers" in stages else ():
        spec = tier(name)
        tasks += [
            EpisodeTask(
                run_on(agent, i),
                tier_label(name),
                0.0,
                seed,
                spec.env_id,
                tuple(sorted(spec.settings.items())),
            )
            for i, seed in enumerate(seeds)
            for agent in TIER_AGENTS
        ]
    return tasks


def failure_table(rows: Sequence[EpisodeRow]) -> list[CalibrationCell]:
    """Failure rate with its 95 % interval (Wilson: each agent is one run here) per (factor, agent)."""
    groups: dict[tuple[str, str], list[EpisodeRow]] = {}
    for row in rows:
        groups.setdefault((row["factor"], base_agent_name(row["agent"])), []).append(row)
    return [CalibrationCell(factor, agent, *failure(members)) for (factor, agent), members in groups.items()]


def pick_course(table: list[CalibrationCell]) -> tuple[dict[str, float] | None, dict[str, CalibrationCell]]:
    """The chosen candidate (None if no candidate's best agent lands in the config's ``target_failure``) and, per
    candidate label, its best agent's row."""
    best: dict[str, CalibrationCell] = {}
    for row in table:
        if row.factor.startswith("tier:"):
            continue
        if row.factor not in best or row.failure_rate < best[row.factor].failure_rate:
            best[row.factor] = row
    low, high = STUDY.target_failure
    middle = (low + high) / 2.0
    inside = [
        course
        for course in STUDY.courses
        if course_label(course) in best and low <= best[course_label(course)].failure_rate <= high
    ]
    if not inside:
        return None, best
    chosen = min(
        inside,
        key=lambda c: (
            abs(best[course_label(c)].failure_rate - middle),
            c["forward_speed"],
            c["obstacle_density"],
        ),
    )
    return dict(chosen), best


def separated_pairs(episodes: Sequence[EpisodeRow]) -> tuple[int, int]:
    """(pairs of agents a paired test tells apart, all pairs) among the ``episodes`` of one factor: each pair
    compared on the layouts both flew, paired by layout (:func:`agents.analysis.paired.compare`), apart where
    the 95 % interval of the difference excludes zero."""
    failures: dict[str, dict[int, float]] = {}
    for row in episodes:
        failures.setdefault(base_agent_name(row["agent"]), {})[int(row["seed"])] = float(not row["success"])
    names = list(failures)
    pairs = [(a, b) for i, a in enumerate(names) for b in names[i + 1 :]]
    apart = 0
    for a, b in pairs:
        shared = sorted(set(failures[a]) & set(failures[b]))
        matrices = [np.array([[failures[name][seed] for seed in shared]]) for name in (a, b)]
        apart += compare(a, matrices[0], b, matrices[1]).fails_less is not None
    return apart, len(pairs)


def run_calibration(
    out: Path,
    *,
    layouts: int = STUDY.layouts,
    workers: int = 2,
    report_only: bool = False,
    stages: Sequence[str] = STAGES,
) -> CalibrationResult:
    """Fly ``stages`` (none if ``report_only``) into ``out`` and return what the report needs from every
    stage flown so far: the table, the chosen course, whether it is the frozen one, each tier's best agent."""
    out = Path(out)
    check_writable_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    tasks = calibration_tasks(layouts)
    csv_path = out / EPISODES_CSV
    if not report_only:
        execute(calibration_tasks(layouts, stages), csv_path, workers=workers, description="calibrate tiers")
    rows = rows_of(tasks, read_records(csv_path)) if csv_path.is_file() else []
    table = failure_table(rows)
    chosen, best_per_course = pick_course(table)
    tiers: dict[str, CalibratedTier] = {}
    for name in CALIBRATED_TIERS:
        mine = sorted((r for r in table if r.factor == tier_label(name)), key=lambda r: r.failure_rate)
        if mine:
            flown = [r for r in rows if r["factor"] == tier_label(name)]
            tiers[name] = CalibratedTier(rows=mine, best=mine[0], separated=separated_pairs(flown))
    pilot = read_records(out / PILOT_CSV) if (out / PILOT_CSV).is_file() else []
    return CalibrationResult(
        pilot=failure_table(pilot),
        # The env settings each pilot factor was flown with, as the records carry them.
        pilot_settings={row["factor"]: row["env_kwargs"] or "{}" for row in pilot},
        layouts=layouts,
        table=table,
        chosen=chosen,
        frozen_matches=chosen is not None and canonical_json(chosen) == canonical_json(HARD_COURSE),
        best_per_course=best_per_course,
        tiers=tiers,
    )


@dataclass(frozen=True)
class TierCalibrationValues:
    """Every value ``calibration.md`` words (``templates/calibration.md.j2``): the study's design, the candidate
    courses' cells by course and agent (the best per course, the pick), the pilot's cells and the settings each
    pilot factor flew with (in the order they were first flown), and each calibrated tier with its spec."""

    generated: str
    command: str
    episodes_csv: str
    first: int
    layouts: int
    courses: list[tuple[str, dict[str, float]]]
    course_agents: tuple[str, ...]
    target: tuple[float, ...]
    cells: dict[str, dict[str, CalibrationCell]]
    best_per_course: dict[str, CalibrationCell]
    chosen: dict[str, float] | None
    chosen_label: str
    frozen_matches: bool
    hard_course: str
    pilot_start: int
    pilot_csv: str
    pilot_cells: dict[str, dict[str, CalibrationCell]]
    pilot_settings: dict[str, dict[str, object]]
    tiers: dict[str, CalibratedTier]
    specs: dict[str, Tier]
    headroom: float


def report_lines(result: CalibrationResult, command: str) -> list[str]:
    """``calibration.md``: the search as it happened, the pick and how it compares with the frozen tiers."""
    cells: dict[str, dict[str, CalibrationCell]] = {}
    pilot_cells: dict[str, dict[str, CalibrationCell]] = {}
    for found, rows in ((cells, result["table"]), (pilot_cells, result["pilot"])):
        for row in rows:
            found.setdefault(row.factor, {})[row.agent] = row
    chosen = result["chosen"]
    values = TierCalibrationValues(
        generated=today(),
        command=command,
        episodes_csv=EPISODES_CSV,
        first=TIER_CALIBRATION_SEED_START,
        layouts=result["layouts"],
        courses=[(course_label(course), course) for course in STUDY.courses],
        course_agents=COURSE_AGENTS,
        target=tuple(STUDY.target_failure),
        cells=cells,
        best_per_course=result["best_per_course"],
        chosen=chosen,
        chosen_label="" if chosen is None else course_label(chosen),
        frozen_matches=result["frozen_matches"],
        hard_course=course_label(HARD_COURSE),
        pilot_start=SENSOR_PILOT_SEED_START,
        pilot_csv=PILOT_CSV,
        pilot_cells=pilot_cells,
        pilot_settings={factor: json.loads(text) for factor, text in result["pilot_settings"].items()},
        tiers=result["tiers"],
        specs={name: tier(name) for name in result["tiers"]},
        headroom=HEADROOM_FAILURE,
    )
    return render_report("calibration.md.j2", values).split("\n")[:-1]


class CalibrationFlights(TypedDict, total=False):
    """The options of :func:`run_calibration` that say how it flies."""

    layouts: int
    workers: int
    report_only: bool
    stages: Sequence[str]


def write_calibration(out: Path, command: str, **flights: Unpack[CalibrationFlights]) -> list[str]:
    """:func:`run_calibration` (``flights`` its options) and ``out/calibration.md`` written; returns its lines."""
    lines = report_lines(run_calibration(out, **flights), command)
    write_text_atomically(Path(out) / "calibration.md", "\n".join(lines) + "\n")
    return lines
