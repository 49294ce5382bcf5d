"""The flow rules at finer depth histograms, chosen on validation layouts (``flownav rule-resolution``).

``histogram_sectors`` and ``depth_bin_edges`` are settings any agent may ask any tier for; the camera-limited
planner's flow student asks for 3 x 15 sectors and finer bins. Here each flow rule (:data:`RULES`), with its tuned
gains and its law read in shares of the view (:mod:`agents.policies.view_bands`), flies its own resolution
(:data:`TODAY`) and each of :data:`CANDIDATES` on suite v2's hard tiers (:data:`TIERS`), on the same validation
layouts from :data:`~agents.common.seeds.RULE_RESOLUTION_SEED_START`. A candidate is compared with the rule's own
resolution paired by (tier, layout) (:func:`agents.analysis.paired.compare`); it is picked for the rule only where
the interval of the difference lies wholly below 0, the largest drop among such.

Three stages: the search above; the refinement, a second stage stated after the search and before it flew, which
flies :data:`REFINE_RULE` at its own resolution and each of :data:`REFINE_CANDIDATES` on more, fresh layouts from
:data:`~agents.common.seeds.RULE_RESOLUTION_REFINE_SEED_START` and picks by the same rule; and the confirmation:
a pick (the search's, or for :data:`REFINE_RULE` the refinement's) is the best of several, so it flies again, with
the rule's own resolution, on fresh layouts from :data:`~agents.common.seeds.RULE_RESOLUTION_CONFIRM_SEED_START`:
confirmed only where that interval lies wholly below 0 too. Every episode goes to ``<out>/episodes.csv``
(resumable: a run flies only what it lacks). The rules, tiers, candidates and layouts per stage are
``configs/studies/rule_resolution.yaml`` (:data:`STUDY`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from agents.analysis.episode_record import EpisodeRow
from agents.analysis.paired import Comparison, compare
from agents.analysis.records import read_records
from agents.analysis.statistics import wilson_interval
from agents.common.folders import check_writable_folder
from agents.common.seeds import (
    RULE_RESOLUTION_CONFIRM_SEED_START,
    RULE_RESOLUTION_LAYOUTS,
    RULE_RESOLUTION_REFINE_SEED_START,
    RULE_RESOLUTION_SEED_START,
)
from agents.evaluation.episode_tasks import EpisodeTask, rows_of
from agents.evaluation.runner import execute
from agents.policies.histogram_resolution import HistogramResolution
from agents.studies.study_configs import rule_resolution_config
from flownav_env.tiers import check_agent_settings, tier

# The study's choices (configs/studies/rule_resolution.yaml says why each); the names below are read from it.
STUDY = rule_resolution_config()
RULES = tuple(STUDY.rules)
TIERS = tuple(STUDY.tiers)
TODAY = HistogramResolution()
CANDIDATES = STUDY.candidate_resolutions
SEARCH_RESOLUTIONS = (TODAY, *CANDIDATES)
REFINE_RULE = STUDY.refine_rule
REFINE_CANDIDATES = STUDY.refine_resolutions
RESOLUTIONS = (*SEARCH_RESOLUTIONS, *(r for r in REFINE_CANDIDATES if r not in SEARCH_RESOLUTIONS))
EPISODES_FILE = "episodes.csv"
STAGES = {
    "search": RULE_RESOLUTION_SEED_START,
    "refinement": RULE_RESOLUTION_REFINE_SEED_START,
    "confirmation": RULE_RESOLUTION_CONFIRM_SEED_START,
}


def layout_seeds(stage: str, layouts: int) -> range:
    """The first ``layouts`` validation layouts of ``stage`` (``search``, ``refinement`` or ``confirmation``).

    Raises:
        ValueError: an unknown stage, or ``layouts`` not an integer in [1, RULE_RESOLUTION_LAYOUTS].
    """
    if stage not in STAGES:
        raise ValueError(f"stage must be one of {', '.join(STAGES)}, got {stage!r}")
    if (
        isinstance(layouts, bool)
        or not isinstance(layouts, int)
        or not 1 <= layouts <= RULE_RESOLUTION_LAYOUTS
    ):
        raise ValueError(
            f"{stage} layouts must be an integer in [1, {RULE_RESOLUTION_LAYOUTS}], got {layouts!r}"
        )
    return range(STAGES[stage], STAGES[stage] + layouts)


def resolution_named(name: str) -> HistogramResolution:
    """The resolution of this study called ``name`` (``3x15-9bins``).

    Raises:
        ValueError: no resolution of the study has that name; the message lists them.
    """
    for resolution in RESOLUTIONS:
        if resolution.name == name:
            return resolution
    names = ", ".join(r.name for r in RESOLUTIONS)
    raise ValueError(f"resolution must be one of {names}, got {name!r}")


def resolution_tasks(rule: str, resolution: HistogramResolution, seeds: range) -> list[EpisodeTask]:
    """``rule`` at ``resolution`` on every tier of :data:`TIERS`, layout by layout; each episode is labelled
    ``<tier>/<resolution>`` in the factor column, so resolutions and tiers never share an episode's key.

    Raises:
        ValueError: a rule not in :data:`RULES`, or settings a tier refuses.
    """
    if rule not in RULES:
        raise ValueError(f"rule must be one of {', '.join(RULES)}, got {rule!r}")
    settings = resolution.env_kwargs()
    tasks = []
    for name in TIERS:
        check_agent_settings(rule, settings, name, version=STUDY.suite_version)
        tasks += [
            EpisodeTask(
                rule,
                f"{name}/{resolution.name}",
                0.0,
                seed,
                env_id=tier(name, STUDY.suite_version).env_id,
                env_kwargs=tuple(sorted(settings.items())),
                bee_params=tuple(sorted(resolution.rule_parameters().items())),
            )
            for seed in seeds
        ]
    return tasks


def failures(tasks: list[EpisodeTask], rows: Sequence[EpisodeRow]) -> np.ndarray | None:
    """Failures (1, tasks) in the tasks' order (a failure: no success), or None while one is not flown."""
    by_key = {(row["factor"], int(row["seed"])): row for row in rows_of(tasks, rows)}
    found = [by_key.get((task.factor, task.seed)) for task in tasks]
    if any(row is None for row in found):
        return None
    return np.array([[0.0 if row["success"] else 1.0 for row in found if row is not None]])


@dataclass(frozen=True)
class ResolutionRow:
    """A rule at one resolution on one stage's layouts (both tiers pooled): its failure with a Wilson interval,
    per tier, and against the rule's own resolution paired by (tier, layout) (None for that one)."""

    stage: str
    rule: str
    resolution: str
    episodes: int
    failure: float
    low: float
    high: float
    per_tier: dict[str, float]
    versus_today: Comparison | None


@dataclass(frozen=True)
class RuleResolutionResult:
    """What the study found: its rows, per rule the resolution the search picked (None: none), the refinement's
    pick for :data:`REFINE_RULE` (None: none, or not flown yet), per rule the pick sent to the confirmation (the
    search's, or the refinement's for :data:`REFINE_RULE`) and whether the confirmation bore it out (None: nothing
    to confirm, or not flown yet), the layouts per tier of each stage, how many (rule, resolution) configurations
    were tried, and the rows still short of episodes."""

    rows: list[ResolutionRow]
    picks: dict[str, str | None]
    refined: str | None
    chosen: dict[str, str | None]
    confirmed: dict[str, bool | None]
    layouts: dict[str, int]
    configurations_tried: int
    missing: list[str]


def _row(
    stage: str, rule: str, resolution: HistogramResolution, outcome: np.ndarray, today: np.ndarray | None
):
    total = outcome.size
    low, high = wilson_interval(int(total - outcome.sum()), total)
    per_tier = {
        name: float(part.mean()) for name, part in zip(TIERS, np.split(outcome[0], len(TIERS)), strict=True)
    }
    versus = None if today is None else compare(resolution.name, outcome, TODAY.name, today)
    # Wilson's interval is of the success rate; failure's is its mirror.
    return ResolutionRow(
        stage, rule, resolution.name, total, float(outcome.mean()), 1 - high, 1 - low, per_tier, versus
    )


def pick(rows: Sequence[ResolutionRow]) -> str | None:
    """Of one rule's candidate rows, the resolution whose paired interval against the rule's own lies wholly below
    0 with the largest drop (the coarser on a tie); None where no interval does."""
    below = [row for row in rows if row.versus_today is not None and row.versus_today.high < 0.0]
    if not below:
        return None
    return min(below, key=lambda row: row.versus_today.difference if row.versus_today else 0.0).resolution


def _stage_rows(
    stage: str,
    rule: str,
    resolutions: Sequence[HistogramResolution],
    seeds: range,
    flown: Sequence[EpisodeRow],
) -> tuple[list[ResolutionRow], list[str]]:
    """The rule's rows on a stage, its own resolution first; and those short of episodes."""
    rows, missing = [], []
    today = failures(resolution_tasks(rule, TODAY, seeds), flown)
    for resolution in resolutions:
        outcome = failures(resolution_tasks(rule, resolution, seeds), flown)
        if outcome is None:
            missing.append(f"{rule} at {resolution.name} ({stage})")
            continue
        rows.append(_row(stage, rule, resolution, outcome, None if resolution == TODAY else today))
    return rows, missing


def _searched(
    seeds: dict[str, range], flown: Sequence[EpisodeRow]
) -> tuple[list[ResolutionRow], list[str], dict[str, str | None], str | None]:
    """The search's and the refinement's rows, those short of episodes, each rule's search pick and the
    refinement's pick."""
    rows, missing, picks = [], [], {}
    for rule in RULES:
        found, short = _stage_rows("search", rule, SEARCH_RESOLUTIONS, seeds["search"], flown)
        rows += found
        missing += short
        picks[rule] = None if short else pick(found)
    found, short = _stage_rows(
        "refinement", REFINE_RULE, (TODAY, *REFINE_CANDIDATES), seeds["refinement"], flown
    )
    return rows + found, missing + short, picks, None if short else pick(found)


def _confirmed(
    picked: Sequence[tuple[str, HistogramResolution]], seeds: range, csv_path: Path, report_only: bool
) -> tuple[list[ResolutionRow], list[str], dict[str, bool | None]]:
    """Fly (unless ``report_only``) each pick and its rule's own resolution on the confirmation layouts; their
    rows, those short of episodes, and per rule whether the pick is confirmed (None: nothing to confirm, or not
    flown yet)."""
    if picked and not report_only:
        tasks = [
            t
            for rule, r in picked
            for t in (*resolution_tasks(rule, TODAY, seeds), *resolution_tasks(rule, r, seeds))
        ]
        execute(tasks, csv_path, workers=1, description="rule resolutions, confirmation")
    flown = read_records(csv_path) if csv_path.is_file() else []
    rows, missing = [], []
    confirmed: dict[str, bool | None] = dict.fromkeys(RULES)
    for rule, resolution in picked:
        found, short = _stage_rows("confirmation", rule, (TODAY, resolution), seeds, flown)
        rows += found
        missing += short
        comparison = found[-1].versus_today if not short else None
        confirmed[rule] = None if comparison is None else comparison.high < 0.0
    return rows, missing, confirmed


def run_rule_resolution(
    out: Path,
    *,
    search_layouts: int = STUDY.layouts.search,
    refine_layouts: int = STUDY.layouts.refinement,
    confirm_layouts: int = STUDY.layouts.confirmation,
    report_only: bool = False,
) -> RuleResolutionResult:
    """Fly (unless ``report_only``) the search, the refinement, then the confirmation of each pick, into
    ``<out>/episodes.csv`` with one worker; compare and pick.

    Raises:
        ValueError: a layout count out of range, or an unwritable ``out``.
    """
    seeds = {
        "search": layout_seeds("search", search_layouts),
        "refinement": layout_seeds("refinement", refine_layouts),
        "confirmation": layout_seeds("confirmation", confirm_layouts),
    }
    out = Path(out)
    check_writable_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    csv_path = out / EPISODES_FILE
    stage_configurations = {
        "search": [(rule, r) for rule in RULES for r in SEARCH_RESOLUTIONS],
        "refinement": [(REFINE_RULE, r) for r in (TODAY, *REFINE_CANDIDATES)],
    }
    if not report_only:
        for stage, configurations in stage_configurations.items():
            tasks = [t for rule, r in configurations for t in resolution_tasks(rule, r, seeds[stage])]
            execute(tasks, csv_path, workers=1, description=f"rule resolutions, {stage}")
    flown = read_records(csv_path) if csv_path.is_file() else []
    rows, missing, picks, refined = _searched(seeds, flown)
    chosen = {rule: refined if rule == REFINE_RULE else picks[rule] for rule in RULES}
    picked = [(rule, resolution_named(name)) for rule, name in chosen.items() if name is not None]
    confirm_rows, confirm_missing, confirmed = _confirmed(
        picked, seeds["confirmation"], csv_path, report_only
    )
    layouts = {"search": search_layouts, "refinement": refine_layouts, "confirmation": confirm_layouts}
    # Each (rule, resolution) flown in any stage: the search's 12 and the refinement's resolutions it did not try.
    tried = len({(rule, r) for configurations in stage_configurations.values() for rule, r in configurations})
    return RuleResolutionResult(
        rows + confirm_rows, picks, refined, chosen, confirmed, layouts, tried, missing + confirm_missing
    )
