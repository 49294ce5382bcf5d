"""``suite_with_included``: agents scored with ``flownav score`` set beside the published suite and ranked
exactly as ``suite.md`` ranks (:func:`~agents.evaluation.suite_ranking.rank_suite`; worded by the same template,
:mod:`agents.pages.included_page`):
privileged references apart, each ranked agent's difference from the best, its Holm-corrected p-value, and
whether it joins the tier's top group.

A ranking compares agents on the same layouts, so every row here rests on the first N frozen layouts, N the
fewest an included row flew: the published agents' episodes (``suite_episodes.csv`` beside the published
CSV) are counted again on them. Which episode rows are an agent's runs is read from ``score_runs.json``, which
``flownav score`` writes beside its ``score.csv``; a FlowNav agent without one is its shipped runs.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from agents.analysis.paired import TierRanking
from agents.analysis.records import read_records
from agents.common.seeds import suite_seeds
from agents.evaluation.episode_tasks import TieredRow, with_tier
from agents.evaluation.suite import EPISODES_CSV, agent_runs, summarise_suite
from agents.evaluation.suite_ranking import rank_suite, tier_failures
from agents.evaluation.suite_report import (
    SuiteRow,
    merge_rows,
    read_included,
    read_score_runs,
    read_suite_csv,
)
from agents.evaluation.verification_record import verification_mark
from agents.policies import split_agent_name
from agents.policies.agent_limits import ISOLATION_PROCESS, NO_SANDBOX_OPTION
from flownav_env.tiers import SUITE_VERSION, TIER_NAMES


def _runs_of(folder: Path, agents: Sequence[str]) -> dict[str, list[str]]:
    """Each of ``agents``' run names: from ``folder``'s :data:`SCORE_RUNS_JSON`, else a FlowNav agent's shipped
    runs; an agent with neither has none (it cannot be ranked)."""
    recorded = read_score_runs(folder)
    runs = {}
    for agent in agents:
        if agent in recorded:
            runs[agent] = recorded[agent]
            continue
        try:
            split_agent_name(agent)
            runs[agent] = agent_runs(agent)
        except (ValueError, FileNotFoundError):
            continue
    return runs


def _episodes(
    folder: Path, runs: Mapping[str, Sequence[str]], seeds: Sequence[int], version: str
) -> list[TieredRow]:
    """Suite ``version``'s episodes of ``runs`` on ``seeds`` in ``folder``'s episodes CSV, with their tiers."""
    path = Path(folder) / EPISODES_CSV
    if not path.is_file():
        return []
    names = {name for names in runs.values() for name in names}
    wanted = set(seeds)
    return [
        with_tier(row)
        for row in read_records(path)
        if row["agent"] in names and int(row["seed"]) in wanted and row.get("suite_version") == version
    ]


def _source(
    csv_path: Path, rows: Sequence[Mapping[str, object]], layouts: int, version: str, *, included: bool | str
) -> tuple[list[SuiteRow], dict[str, dict[str, np.ndarray]], list[tuple[str, str]]]:
    """One CSV's rows counted again on the first ``layouts`` layouts from its episodes: the summary rows, each
    tier's failure matrices (``included``: what marks its rows, an included file's verification), and the (agent,
    tier) pairs of its rows whose episodes are not beside it (or not on
    every one of the layouts)."""
    agents = list(dict.fromkeys(str(row["agent"]) for row in rows))
    runs = _runs_of(csv_path.parent, agents)
    seeds = list(suite_seeds(layouts, version))
    episodes = _episodes(csv_path.parent, runs, seeds, version)
    privileged = {str(row["agent"]): bool(row["privileged"]) for row in rows}
    tiers = [name for name in TIER_NAMES if any(row["tier"] == name for row in rows)]
    table = summarise_suite(episodes, runs, tiers, layouts, version, privileged=privileged)
    for row in table:
        row["included"] = included
    whole = {(row["tier"], row["agent"]) for row in table}
    missing = [
        (str(row["agent"]), str(row["tier"])) for row in rows if (row["tier"], row["agent"]) not in whole
    ]
    failures = {name: tier_failures(episodes, runs, name, seeds) for name in tiers}
    return table, failures, missing


def included_mark(score_csv: Path, verified_now: Mapping[Path, str]) -> str:
    """How the included rows of ``score_csv`` are marked: verified in this command (``verified_now``), verified
    by a signed record beside them, or self-reported; and whether any of its episodes flew without the sandbox."""
    mark = verified_now.get(Path(score_csv)) or verification_mark(Path(score_csv))
    episodes = Path(score_csv).parent / EPISODES_CSV
    if episodes.is_file() and any(row["isolation"] == ISOLATION_PROCESS for row in read_records(episodes)):
        mark += f"; flown without the sandbox ({NO_SANDBOX_OPTION})"
    return mark


def agent_to_verify(score_csv: Path) -> str:
    """The agent whose rows ``score_csv`` holds, as ``flownav score`` was given it (a file's or module's full spec,
    a model's ``<algo>:<zip>``, a FlowNav name), read from the ``score_runs.json`` beside it.

    Raises:
        ValueError: rows of several agents, or none with recorded runs.
    """
    rows = read_suite_csv(Path(score_csv), SUITE_VERSION)
    names = sorted({str(row["agent"]) for row in rows})
    runs = read_score_runs(Path(score_csv).parent)
    if len(names) != 1 or names[0] not in runs:
        raise ValueError(
            f"--verify: {score_csv} must hold the rows of one agent with its runs in score_runs.json beside it (as "
            f"flownav score writes), got agents {names}: verify it with flownav verify instead"
        )
    flown = runs[names[0]]
    return flown[0] if len(flown) == 1 else split_agent_name(flown[0])[0]


@dataclass(frozen=True)
class IncludedSuite:
    """The published suite with included agents ranked among its agents (:func:`included_suite`), for its page
    (:func:`agents.pages.included_page.included_page`).

    Attributes:
        table: the rows, an included one with its ``included`` mark.
        failures: each tier's failure matrices, agent → (runs, layouts) on the first ``layouts`` layouts.
        rankings: each tier's ranking.
        files: the score files read; ``marks`` how each one's rows are marked (its verification).
        not_counted: the (agent, tier) rows that could not be counted again (no episodes beside their CSV).
        layouts: the layouts every row rests on, the fewest an included row flew.
        version: the suite version.
        folder: the published suite's folder; ``published_episodes`` its agents' episodes on those layouts.
    """

    table: list[SuiteRow]
    failures: dict[str, dict[str, np.ndarray]]
    rankings: dict[str, TierRanking]
    files: list[Path]
    marks: dict[Path, str]
    not_counted: list[tuple[str, str]]
    layouts: int
    version: str
    folder: Path
    published_episodes: list[TieredRow]


def included_suite(
    suite_csv: Path,
    score_csvs: Sequence[str | Path],
    *,
    version: str = SUITE_VERSION,
    verified_now: Mapping[Path, str] | None = None,
) -> IncludedSuite:
    """The published suite (of suite ``version``) with the agents of ``score_csvs`` ranked among its agents;
    ``verified_now`` marks the files re-flown in this command.

    Raises:
        ValueError: an included row on fewer than 2 layouts, or a bad suite or score CSV (:func:`read_included`).
        FileNotFoundError: no CSV at a path given.
    """
    published = read_suite_csv(Path(suite_csv), version)
    included, files = read_included(score_csvs, version)
    layouts = min(row["layouts"] for row in included)
    if layouts < 2:
        raise ValueError(
            f"an included row rests on {layouts} layout; a ranking compares agents on at least 2: score it with "
            "flownav score --layouts 2 or more"
        )
    table, failures, missing = _source(Path(suite_csv), published, layouts, version, included=False)
    marks = {path: included_mark(path, verified_now or {}) for path in files}
    for path in files:
        mark = marks[path]
        rows, matrices, not_whole = _source(
            path, read_suite_csv(path, version), layouts, version, included=mark
        )
        table = merge_rows(table, rows)
        missing += not_whole
        for name, found in matrices.items():
            failures.setdefault(name, {}).update(found)
    folder = Path(suite_csv).parent
    seeds = list(suite_seeds(layouts, version))
    published_runs = _runs_of(folder, list(dict.fromkeys(str(row["agent"]) for row in published)))
    return IncludedSuite(
        table=table,
        failures=failures,
        rankings=rank_suite(table, failures),
        files=list(files),
        marks=marks,
        not_counted=missing,
        layouts=layouts,
        version=version,
        folder=folder,
        published_episodes=_episodes(folder, published_runs, seeds, version),
    )
