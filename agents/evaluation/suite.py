"""The benchmark suite: any agent on every tier's frozen test layouts, one row per (agent, tier).

The tiers are :mod:`flownav_env.tiers`' (frozen under ``SUITE_VERSION``), the layouts
:func:`agents.common.seeds.suite_seeds` (a test sub-range nothing was chosen on). A learned agent named alone flies
every shipped training seed on every layout, so its intervals span training runs and layouts, as the leaderboard's
do; any other agent (reactive, ``module:callable``, ``file.py:callable``, an SB3 ``--policy --algo``) is one run.
Episodes go to a resumable episodes CSV through the same runner as ``evaluate`` and ``sweep`` (local pool or Ray),
each stamped with the suite version.

``agents.evaluation.scoring.score`` scores one agent: ``flownav score`` is its command line.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TypedDict, cast

import numpy as np

from agents.analysis.episode_record import EpisodeRow
from agents.analysis.over_seeds import episode_outcomes
from agents.analysis.paired import RUNS_INTERVAL, runs_interval
from agents.analysis.records import read_records
from agents.analysis.statistics import wilson_interval
from agents.common.folders import check_writable_folder, write_text_atomically
from agents.common.locations import POLICIES_DIR, RESULTS_DIR
from agents.common.seeds import SUITE_LAYOUTS, suite_seeds
from agents.evaluation.episode_tasks import EpisodeTask, TieredRow, rows_of, suite_task, with_tier
from agents.evaluation.runner import execute
from agents.evaluation.suite_ranking import rank_suite, tier_failures
from agents.evaluation.suite_report import OUTCOMES, SUMMARY_COLUMNS, SuiteRow
from agents.policies import (
    agent_env_kwargs,
    check_flown_on,
    check_not_retired,
    default_runs,
    is_learned,
    is_per_tier,
    is_privileged,
    load_agent,
    policy_file,
    runs_to_fly,
    split_agent_name,
    suite_agents_of,
)
from agents.policies.agent_limits import AgentLimits
from agents.policies.external import canonical_spec, is_external_name
from agents.policies.sb3_models import is_sb3_model_name
from flownav_env.tiers import SUITE_VERSION, TIER_NAMES, check_agent_settings, tier

# The file a suite's episodes are kept in, in its folder.
EPISODES_CSV = "suite_episodes.csv"
# Where each suite version's published files lie under results/: the current version at the top, earlier ones as
# history in their own folder.
SUITE_RESULTS_FOLDERS = {"1": "suite_v1", "2": "."}


def published_suite_csv(version: str = SUITE_VERSION) -> Path:
    """The published ``suite.csv`` of suite ``version``."""
    return RESULTS_DIR / SUITE_RESULTS_FOLDERS[version] / "suite.csv"


def parse_tiers(text: str | Sequence[str]) -> list[str]:  # the tier names are the same in every version
    """``"all"`` or comma-separated tier names (or a list of them) → the tier names, in suite order.

    Raises:
        ValueError: an unknown tier, or none.
    """
    names = [name.strip() for name in text.split(",")] if isinstance(text, str) else list(text)
    names = [name for name in names if name]
    if names == ["all"]:
        return list(TIER_NAMES)
    if not names:
        raise ValueError(f"give at least one tier: all, or some of {', '.join(TIER_NAMES)}")
    for name in names:
        tier(name)
    return [name for name in TIER_NAMES if name in names]


def agent_runs(agent: str, policy: str | None = None) -> list[str]:
    """The runs ``agent`` is in the suite: a learned agent named alone is every shipped training seed
    (``ppo_flow@0`` ...); anything else is itself.

    Raises:
        ValueError: an unknown agent name.
        FileNotFoundError: a learned agent with no policy shipped.
    """
    return runs_to_fly(agent, policy)[0]


def _check_agent_fits_tier(name: str, policy: str | None, tier_name: str, version: str) -> None:
    """An agent may choose observation keys, never change the task a tier fixes; privileged data only when it
    is declared privileged (:func:`flownav_env.tiers.check_agent_settings`)."""
    path = policy_file(name, policy, directory=POLICIES_DIR) if is_learned(name) else policy
    check_agent_settings(
        name, agent_env_kwargs(name, path), tier_name, privileged=is_privileged(name), version=version
    )


def suite_tasks(
    runs: Mapping[str, Sequence[str]],
    tiers: Sequence[str],
    layouts: int = SUITE_LAYOUTS,
    *,
    policies: Mapping[str, str | None] | None = None,
    trust_pickle: bool = False,
    version: str = SUITE_VERSION,
) -> list[EpisodeTask]:
    """Every run of every agent on the first ``layouts`` frozen layouts of each tier of suite ``version``, tier by
    tier and layout by layout (an interrupted flight leaves every run with about the same layouts).

    Args:
        runs: agent → its run names (:func:`agent_runs`).
        tiers: tier names.
        layouts: how many of the frozen layouts (a prefix of them).
        policies: agent → its policy file where it is not the shipped one.
        trust_pickle: load policy zips without their config by unpickling them (the user's opt-in).

    Raises:
        ValueError: a bad tier or layout count, or an agent that sets a setting a tier fixes.
    """
    policies = policies or {}
    seeds = suite_seeds(layouts, version)
    tasks = []
    for tier_name in tiers:
        spec = tier(tier_name, version)
        flown = {
            agent: _tier_policies(names, policies.get(agent), tier_name) for agent, names in runs.items()
        }
        flown = {agent: files for agent, files in flown.items() if files}
        for files in flown.values():
            name, policy = next(iter(files.items()))
            _check_agent_fits_tier(name, policy, tier_name, version)
        for seed in seeds:
            for files in flown.values():
                for name, policy in files.items():
                    tasks.append(
                        suite_task(
                            name,
                            tier_name,
                            seed,
                            env_id=spec.env_id,
                            settings=spec.settings,
                            suite_version=version,
                            policy=policy,
                            trust_pickle=trust_pickle,
                        )
                    )
    return tasks


def _tier_policies(names: Sequence[str], policy: str | None, tier_name: str) -> dict[str, str | None]:
    """Each run of an agent that flies ``tier_name`` → its policy file (None: the shipped one). An agent
    learned once per tier flies the runs that tier ships, each from that tier's folder; none where the tier
    ships none yet (the report lists the pair as not flown)."""
    if policy is not None or not is_per_tier(names[0]):
        return dict.fromkeys(names, policy)
    files = {name: policy_file(name, directory=POLICIES_DIR, tier=tier_name) for name in names}
    return {name: str(path) for name, path in files.items() if path.is_file()}


def suite_rows(tasks: Sequence[EpisodeTask], csv_path: Path) -> list[TieredRow]:
    """The episodes of ``tasks`` in the episodes CSV at ``csv_path``, each with its ``tier``."""
    return [with_tier(row) for row in rows_of(list(tasks), read_records(csv_path))]


def summarise_suite(
    rows: Iterable[TieredRow],
    runs: Mapping[str, Sequence[str]],
    tiers: Sequence[str],
    layouts: int = SUITE_LAYOUTS,
    version: str = SUITE_VERSION,
    *,
    privileged: Mapping[str, bool] | None = None,
) -> list[SuiteRow]:
    """One row per (agent, tier) with :data:`SUMMARY_COLUMNS` from the suite's episode rows (:func:`suite_rows`):
    each outcome's rate, with a 95 % interval over layouts (Wilson) for one run, or over runs × layouts
    (two-level bootstrap) for several training seeds. Agents and tiers with episodes missing are left out (a
    partial flight reports what is whole). ``privileged`` says which agents are, where known (an included row
    says it), instead of asking each agent.
    """
    rows = list(rows)
    seeds = list(suite_seeds(layouts, version))
    table = []
    for tier_name in tiers:
        tier_rows = [row for row in rows if row["tier"] == tier_name]
        for agent, names in runs.items():
            try:
                outcomes = {name: episode_outcomes(tier_rows, names, seeds, name) for name in OUTCOMES}
            except ValueError:
                continue
            row: dict[str, object] = {
                "suite_version": version,
                "tier": tier_name,
                "env_id": tier(tier_name, version).env_id,
                "agent": agent,
                "runs": len(names),
                "layouts": len(seeds),
                "episodes": len(names) * len(seeds),
                "interval_over": "layouts (Wilson)" if len(names) == 1 else RUNS_INTERVAL,
                "env_kwargs": _flown_settings(tier_rows, names),
                "privileged": privileged[agent]
                if privileged and agent in privileged
                else is_privileged(agent),
            }
            for name, matrix in outcomes.items():
                if len(names) == 1:
                    low, high = wilson_interval(int(matrix.sum()), matrix.size)
                else:
                    low, high = runs_interval(matrix)
                row.update({f"{name}_rate": float(np.mean(matrix)), f"{name}_low": low, f"{name}_high": high})
            # Every column is set above, each as its type.
            table.append(cast(SuiteRow, {column: row[column] for column in SUMMARY_COLUMNS}))
    return table


def _flown_settings(rows: Sequence[EpisodeRow], runs: Sequence[str]) -> str:
    """The env kwargs (JSON) the episodes of ``runs`` were flown with: one set, as every run of an agent on a
    tier flies the same task.

    Raises:
        ValueError: the runs' episodes were flown with different settings.
    """
    flown = {row["env_kwargs"] or "{}" for row in rows if row["agent"] in runs}
    if len(flown) != 1:
        raise ValueError(
            f"runs {', '.join(runs)} were flown with {len(flown)} different settings: {sorted(flown)}"
        )
    return flown.pop()


def resolve_agent(agent: str, *, trust_pickle: bool = False, limits: AgentLimits | None = None) -> str:
    """The name records keep for ``agent``: an outside agent's spec made absolute, after loading it once so
    that a bad one fails before anything flies.

    Raises:
        ValueError: an unknown name, an import path that does not resolve, or a callable that returns
            something without ``predict``.
    """
    split_agent_name(agent)
    if is_external_name(agent):
        agent = agent if is_sb3_model_name(agent) else canonical_spec(agent)
        load_agent(agent, trust_pickle=trust_pickle, limits=limits)
    return agent


def write_summary_csv(path: Path, table: Sequence[Mapping[str, object]]) -> None:
    """The suite's rows as CSV (:data:`SUMMARY_COLUMNS`, rates to 4 decimals), replaced atomically; a row is a
    :class:`SuiteRow` or one kept as its CSV text (:func:`~agents.evaluation.suite_report.other_agents_rows`)."""
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=SUMMARY_COLUMNS, lineterminator="\n")
    writer.writeheader()
    for row in table:
        writer.writerow({k: round(v, 4) if isinstance(v, float) else v for k, v in row.items()})
    write_text_atomically(path, text.getvalue())


def suite_agents(version: str = SUITE_VERSION) -> list[str]:
    """Every agent suite ``version`` reports: those it flies (:func:`~agents.policies.base.suite_agents_of`) but a
    learned agent with no shipped policy yet (one being trained), which has no runs to report."""
    return [agent for agent in suite_agents_of(version) if not is_learned(agent) or default_runs(agent)[0]]


class TierTopGroup(TypedDict):
    """A tier's best ranked agent with its failure, its top group, and whether every agent has flown it in full
    (:func:`suite_top_groups`)."""

    tier: str
    best: str
    best_failure: float
    top_group: list[str]
    complete: bool


def suite_top_groups(
    folder: Path, layouts: int = SUITE_LAYOUTS, version: str = SUITE_VERSION
) -> list[TierTopGroup]:
    """Per tier with any agent flown in full, in suite order: its best ranked agent with its failure, its top
    group, and whether every agent of the suite has flown it in full (``complete``), from ``folder``'s suite
    episodes (the ranking of ``suite.md``).

    Raises:
        FileNotFoundError: no suite episodes in ``folder``.
    """
    path = Path(folder) / EPISODES_CSV
    if not path.is_file():
        raise FileNotFoundError(f"no suite episodes at {path}: flownav suite --out {folder}")
    runs = {agent: agent_runs(agent) for agent in suite_agents(version)}
    tasks = [
        task
        for agent in runs
        for task in suite_tasks({agent: runs[agent]}, TIER_NAMES, layouts, version=version)
    ]
    rows = suite_rows(tasks, path)
    table = summarise_suite(rows, runs, TIER_NAMES, layouts, version)
    seeds = list(suite_seeds(layouts, version))
    rankings = rank_suite(table, {name: tier_failures(rows, runs, name, seeds) for name in TIER_NAMES})
    failure = {(row["tier"], row["agent"]): row["failure_rate"] for row in table}
    return [
        {
            "tier": name,
            "best": ranking.best,
            "best_failure": failure[(name, ranking.best)],
            "top_group": list(ranking.top_group),
            "complete": all((name, agent) in failure for agent in runs),
        }
        for name, ranking in rankings.items()
    ]


@dataclass(frozen=True)
class SuiteFlight:
    """What :func:`run_suite` flew (or found, report-only) in its folder, for its page
    (:func:`agents.pages.suite_writer.write_suite_page`).

    Attributes:
        folder: where the episodes, ``suite.csv`` and the page lie.
        rows: the suite's episodes, each with its tier.
        runs: each agent's runs.
        tiers: the tiers asked for, in suite order.
        layouts: how many of each tier's frozen layouts.
        version: the suite version.
        table: one row per (agent, tier) flown in full (``suite.csv``).
    """

    folder: Path
    rows: list[TieredRow]
    runs: dict[str, list[str]]
    tiers: list[str]
    layouts: int
    version: str
    table: list[SuiteRow]


def run_suite(
    agents: Sequence[str],
    out: str | Path,
    *,
    tiers: str | Sequence[str] = "all",
    layouts: int = SUITE_LAYOUTS,
    workers: int = 2,
    backend: str = "local",
    address: str | None = None,
    report_only: bool = False,
    version: str = SUITE_VERSION,
) -> SuiteFlight:
    """Fly (unless ``report_only``) every agent on the suite, agent by agent in the order given (an interrupted
    flight leaves whole agents), and write ``suite_episodes.csv`` and ``suite.csv`` into ``out``; returns what
    its page is written from.

    Raises:
        ValueError: a bad or retired agent, tier, layout count, worker count or folder.
    """
    tier_names = parse_tiers(tiers)
    if workers < 1:
        raise ValueError(f"--workers must be >= 1, got {workers}")
    runs = {
        agent: agent_runs(resolve_agent(check_flown_on(check_not_retired(agent), version)))
        for agent in agents
    }
    tasks = [
        task
        for agent in runs
        for task in suite_tasks({agent: runs[agent]}, tier_names, layouts, version=version)
    ]
    out = Path(out)
    check_writable_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    csv_path = out / EPISODES_CSV
    if not report_only:
        execute(tasks, csv_path, backend=backend, workers=workers, address=address, description="suite")
    rows = suite_rows(tasks, csv_path) if csv_path.is_file() else []
    table = summarise_suite(rows, runs, tier_names, layouts, version)
    write_summary_csv(out / "suite.csv", table)
    return SuiteFlight(out, rows, runs, tier_names, layouts, version, table)
