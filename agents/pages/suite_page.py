"""``suite.md``: the suite's leading table, per tier, with its ranking decided by paired tests
(:mod:`agents.analysis.paired`): values computed here, worded by ``templates/suite.md.j2``.

Privileged agents are listed apart as references; learned agents with fewer training seeds than
:data:`~agents.analysis.paired.MIN_RANKED_SEEDS` are provisional. Neither is ranked, named best, or decides a
tier's headroom.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TypedDict

import numpy as np

from agents.analysis.decision_rows import AgentDecision
from agents.analysis.paired import (
    BOOTSTRAP_REPS,
    MIN_RANKED_SEEDS,
    SIGNIFICANCE,
    TierRanking,
    compare,
    p_value_error,
)
from agents.analysis.records import read_records
from agents.analysis.reflights import ReflightSummary
from agents.common.jinja_reports import render
from agents.common.locations import RESULTS_DIR
from agents.common.seeds import LANE_SEED_START
from agents.common.tables import markdown_cell
from agents.evaluation.episode_tasks import with_tier
from agents.evaluation.lane import LANE_DIR, NEAR_EDGE_M, LaneRow, SidewaysRow, lane_values
from agents.evaluation.learning_gain import CAMERA_MARGIN, LearningGain
from agents.evaluation.reference_chain import CAMERA_VIEW_REFERENCE, ChainLink
from agents.evaluation.suite_ranking import tier_failures
from agents.evaluation.suite_report import HEADROOM_FAILURE, OUTCOMES, SuiteRow
from agents.evaluation.tier_bound import TierBound
from agents.pages.suite_findings import findings
from agents.pages.suite_types import (
    RetiredAgent,
    RetiredTier,
    SensorReading,
    ShownRow,
    SuiteTier,
    SuiteValues,
)
from agents.pages.velocity_reading import VelocityReading
from agents.policies import (
    NOT_FLOWN_ON,
    RETIRED_AGENTS,
    is_per_tier,
    split_agent_name,
    trained_on,
)
from agents.policies.base import base_agent_name
from agents.policies.trained_tiers import agent_tiers
from flownav_env.sensor_specs import VELOCITY_READINGS, translation_noise_m
from flownav_env.tiers import SUITE_VERSION, SUITE_VERSIONS, TIER_NAMES, tier

# Where the noisy tier flown at other readings of its velocity specification is kept, beside the suite's
# episodes: <agent>_<reading>.csv for each reading of VELOCITY_READINGS (validation layouts).
SENSOR_READING_DIR = "sensor_reading"
SUITE_READING = "per_axis"
# Where recipes for the planner's student are compared per tier (flownav ablation --tier), beside the suite.
STUDENT_RECIPES_DIR = "student_recipes"
# Where recipes for the camera-limited planner's student are compared per tier on suite v2's validation layouts
# (flownav ablation --tiers <tier> --suite-version 2), and where the pick is confirmed on fresh ones.
CAMERA_STUDENT_RECIPES_DIR = "student_recipes_v2"


class BesideSuite(TypedDict):
    """What :func:`beside_suite` reads from beside the suite, as :func:`suite_values` takes it."""

    readings: list[SensorReading]
    recipe_reports: dict[str, str]
    camera_recipe_reports: dict[str, str]
    lanes: list[LaneRow]
    retired: list[RetiredAgent]


def _trained_on(agent: str, version: str = SUITE_VERSION) -> str:
    """The tiers of suite ``version`` a learned agent trained on (all of them for one policy across the tiers),
    else those of an earlier version it trained on, named with their version, else what it trained on in the
    training config's words; a dash for an agent that did not learn."""
    try:
        if is_per_tier(agent):
            return "the tier it flies (one policy per tier)"
        tiers = agent_tiers(agent, version)
        if tiers:
            return "every tier (one policy)" if tiers == TIER_NAMES else ", ".join(tiers)
        for earlier in (v for v in reversed(SUITE_VERSIONS) if v < version):
            tiers = agent_tiers(agent, earlier)
            if tiers:
                named = "every tier" if tiers == TIER_NAMES else ", ".join(tiers)
                return f"v{earlier}: {named} (none of v{version}'s)"
        return trained_on(agent) or "—"
    except (ValueError, OSError):  # an included outside agent: nothing of its training is known here
        return "—"


def _tier_values(
    name: str, rows: Sequence[SuiteRow], ranking: TierRanking, version: str, bound: TierBound | None
) -> SuiteTier:
    by_agent: dict[str, ShownRow] = {
        row["agent"]: {
            **row,
            "trained_on": _trained_on(row["agent"], version),
            "shown": markdown_cell(row["agent"]),
        }
        for row in rows
    }
    compared = {c.agent: c for c in ranking.comparisons}
    ranked: list[ShownRow] = []
    for agent in [ranking.best, *sorted(compared, key=lambda a: (by_agent[a]["failure_rate"], a))]:
        ranked.append(
            {**by_agent[agent], "in_top": agent in ranking.top_group, "comparison": compared.get(agent)}
        )
    apart: list[ShownRow] = [{**by_agent[agent], "why": why} for agent, why in ranking.left_out.items()]
    best = by_agent[ranking.best]
    spec = tier(name, version)
    return SuiteTier(
        name=name,
        env_id=spec.env_id,
        why=spec.why,
        ranked=ranked,
        provisional=sorted((r for r in apart if not r["privileged"]), key=lambda r: r["failure_rate"]),
        references=sorted((r for r in apart if r["privileged"]), key=lambda r: r["failure_rate"]),
        best=best,
        top_group=[markdown_cell(agent) for agent in ranking.top_group],
        room=best["failure_rate"] >= HEADROOM_FAILURE,
        bound=bound,
    )


def _failures_by_seed(path: Path) -> dict[int, float]:
    return {int(row["seed"]): float(not row["success"]) for row in read_records(path)}


def reading_values(folder: Path) -> list[SensorReading]:
    """Per agent flown at the suite's reading and at another one of the noisy tier's velocity specification
    (``<folder>/<agent>_<reading>.csv``), on the same validation layouts: each failure rate and the paired
    difference (other reading − suite's)."""
    found: list[SensorReading] = []
    for path in sorted(Path(folder).glob(f"*_{SUITE_READING}.csv")):
        agent = path.name.removesuffix(f"_{SUITE_READING}.csv")
        suite = _failures_by_seed(path)
        for reading, (meaning, sigma) in VELOCITY_READINGS.items():
            other_path = path.with_name(f"{agent}_{reading}.csv")
            if reading == SUITE_READING or not other_path.is_file():
                continue
            other = _failures_by_seed(other_path)
            seeds = sorted(set(suite) & set(other))
            mine = np.array([[other[seed] for seed in seeds]])
            base = np.array([[suite[seed] for seed in seeds]])
            found.append(
                {
                    "agent": agent,
                    "reading": meaning,
                    "noise_m": translation_noise_m(sigma),
                    "layouts": len(seeds),
                    "first_seed": seeds[0],
                    "suite_failure": float(base.mean()),
                    "failure": float(mine.mean()),
                    "comparison": compare(reading, mine, SUITE_READING, base),
                }
            )
    return found


def suite_values(
    table: Sequence[SuiteRow],
    rankings: Mapping[str, TierRanking],
    *,
    command: str,
    layouts: range,
    machine: str,
    missing: Sequence[str],
    generated: str,
    readings: Sequence[SensorReading] = (),
    bounds: Mapping[str, TierBound] | None = None,
    gains: Sequence[LearningGain] = (),
    recipe_reports: Mapping[str, str] | None = None,
    camera_recipe_reports: Mapping[str, str] | None = None,
    lanes: Sequence[LaneRow] = (),
    sideways: Sequence[SidewaysRow] = (),
    retired: Sequence[RetiredAgent] = (),
    version: str = SUITE_VERSION,
    chains: Mapping[str, Sequence[ChainLink]] | None = None,
    included_files: Sequence[tuple[str, str]] = (),
    figure: str = "suite.png",
    not_counted: Sequence[tuple[str, str]] = (),
    reflights: Sequence[ReflightSummary] = (),
    velocity_reading: VelocityReading | None = None,
    decisions: Mapping[str, Sequence[AgentDecision]] | None = None,
) -> SuiteValues:
    """Every value ``suite.md`` (of suite ``version``) words: the tiers in suite order, each with its ranked,
    provisional and reference rows, its best agent, top group and headroom. With ``included_files`` (score CSVs
    whose rows are marked ``included``, each with its verification) the page is ``suite_with_included.md``, and ``not_counted`` the (agent,
    tier) rows it could not count again (no episodes beside their CSV); ``figure`` is the figure it shows."""
    tiers = [
        _tier_values(
            name,
            [row for row in table if row["tier"] == name],
            rankings[name],
            version,
            (bounds or {}).get(name),
        )
        for name in TIER_NAMES
        if name in rankings
    ]
    # Holm multiplies a tier's smallest p-value by its number of comparisons: the widest error near the cut.
    holm_factor = max([1, *(len(ranking.comparisons) for ranking in rankings.values())])
    return SuiteValues(
        **vars(findings(bounds or {}, chains or {}, gains, decisions or {})),
        suite_version=version,
        current_version=SUITE_VERSION,
        seed_start_name=f'SUITE_SEED_STARTS["{version}"]',
        generated=generated,
        command=command,
        machine=machine,
        reflights=list(reflights),
        velocity_reading=velocity_reading,
        first_layout=layouts.start,
        last_layout=layouts.stop - 1,
        layouts=len(layouts),
        tiers=tiers,
        outcomes=[outcome for outcome in OUTCOMES if outcome != "failure"],
        headroom_failure=HEADROOM_FAILURE,
        min_seeds=MIN_RANKED_SEEDS,
        significance=SIGNIFICANCE,
        bootstrap_draws=BOOTSTRAP_REPS,
        p_value_error=p_value_error(SIGNIFICANCE),
        holm_factor=holm_factor,
        holm_p_value_error=p_value_error(SIGNIFICANCE, multiplier=holm_factor),
        missing=list(missing),
        readings=list(readings),
        suite_noise_m=translation_noise_m(VELOCITY_READINGS[SUITE_READING][1]),
        suite_reading=VELOCITY_READINGS[SUITE_READING][0],
        reading_dir=SENSOR_READING_DIR,
        recipe_reports=dict(recipe_reports or {}),
        camera_recipe_reports=dict(camera_recipe_reports or {}),
        camera_reference=CAMERA_VIEW_REFERENCE,
        camera_margin=CAMERA_MARGIN,
        lanes=list(lanes),
        sideways=list(sideways),
        near_edge_m=NEAR_EDGE_M,
        lane_dir=LANE_DIR,
        lane_seed=LANE_SEED_START,
        retired=list(retired),
        not_flown=dict(NOT_FLOWN_ON.get(version, {})),
        trained_on={gain.learned: _trained_on(gain.learned, version) for gain in gains},
        included_files=list(included_files),
        not_counted=list(not_counted),
        figure=figure,
    )


def beside_suite(
    out: Path, tier_names: Sequence[str], episodes_csv: Path, layouts: Sequence[int]
) -> BesideSuite:
    """What ``suite.md`` reports from flights and reports kept beside it in ``out``: the noisy tier at other
    readings, the student's recipes per tier, the capsule-free lane, and the agents retired from the suite with
    the episodes ``episodes_csv`` kept of them (:func:`suite_values`' arguments)."""
    return {
        "readings": reading_values(Path(out) / SENSOR_READING_DIR),
        "recipe_reports": student_recipe_reports(tier_names),
        "camera_recipe_reports": camera_student_recipe_reports(),
        "lanes": lane_values(Path(out) / LANE_DIR),
        "retired": retired_values(episodes_csv, layouts),
    }


def retired_values(episodes_csv: Path, layouts: Sequence[int]) -> list[RetiredAgent]:
    """Per agent retired from the suite (:data:`~agents.policies.base.RETIRED_AGENTS`), why, and each of its
    training seeds' failure rate per tier over the frozen ``layouts``, for the seeds that flew them all, read
    from the episodes ``episodes_csv`` kept of it (none when it has none there)."""
    rows = [with_tier(row) for row in read_records(episodes_csv)] if Path(episodes_csv).is_file() else []
    found: list[RetiredAgent] = []
    for agent, why in RETIRED_AGENTS.items():
        names = {row["agent"] for row in rows if base_agent_name(row["agent"]) == agent}
        runs = {run: [run] for run in sorted(names, key=lambda run: split_agent_name(run)[1] or 0)}
        tiers: list[RetiredTier] = []
        for name in TIER_NAMES:
            whole = tier_failures(rows, runs, name, layouts)  # only the seeds that flew every layout
            if whole:
                tiers.append({"tier": name, "failures": [float(matrix.mean()) for matrix in whole.values()]})
        found.append({"agent": agent, "why": why, "tiers": tiers})
    return found


def student_recipe_reports(tier_names: Sequence[str]) -> dict[str, str]:
    """Per tier, where ``flownav ablation --tier <tier> --out results/student_recipes/<tier>`` compares recipes
    for the planner's student on the tier's validation layouts, relative to ``results/`` (as every link of
    ``suite.md``; the suite's report lives there)."""
    return {name: f"{STUDENT_RECIPES_DIR}/{name}/ablation.md" for name in tier_names}


def camera_student_recipe_reports() -> dict[str, str]:
    """The camera-limited planner's student's recipe comparisons and confirmations committed under
    ``results/student_recipes_v2/`` (``hard``, ``hard_confirmation``), each folder → its ``ablation.md``, and its
    recipe's minutes per seed (``flownav bench recipe``'s ``training_performance.md``), relative to ``results/``
    (as :func:`student_recipe_reports`' links, wherever the page is written)."""
    folder = RESULTS_DIR / CAMERA_STUDENT_RECIPES_DIR
    pages = sorted([*folder.glob("*/ablation.md"), *folder.glob("*/training_performance.md")])
    return {page.parent.name: page.relative_to(RESULTS_DIR).as_posix() for page in pages}


def suite_page(values: SuiteValues) -> str:
    """``suite.md``'s text from :func:`suite_values`."""
    return render("agents.pages", "suite.md.j2", values, filters={"cell": markdown_cell})
