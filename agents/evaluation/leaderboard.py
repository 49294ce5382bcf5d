"""The clean tier's history table: every agent on the same clean test layouts, learned agents over all their
training seeds (``flownav leaderboard``).

Writes, to the output folder (``run_leaderboard``):

- ``leaderboard_episodes.csv``: every episode (resumable; one agent name per run: ``ppo_flow@3``);
- ``training_seeds.csv``: one row per (agent, training seed) with its episodes and rates;
and returns the table (failure and success rates with 95 % intervals: over layouts for a reactive agent, over
runs × layouts for a learned one, at least the t-interval over its seeds:
:func:`agents.analysis.paired.runs_interval`), the interquartile mean over runs, and the probability that each
learned agent improves on each reactive one (:mod:`agents.analysis.over_seeds`). Its page, ``leaderboard.md``
and ``leaderboard.png``, is :mod:`agents.pages.leaderboard_page`'s.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TypedDict

import numpy as np

import flownav_env  # noqa: F401  (sets MUJOCO_GL before the machine summary queries GL)
from agents.analysis.episode_record import EpisodeRow
from agents.analysis.over_seeds import (
    LAYOUT_BLOCK,
    RunRates,
    block_scores,
    episode_outcomes,
    interval_estimates,
    probability_of_improvement,
    run_rates,
    success_outcomes,
)
from agents.analysis.paired import (
    RUNS_INTERVAL,
    Comparison,
    compare,
    runs_interval,
)
from agents.analysis.records import read_records
from agents.analysis.statistics import wilson_interval
from agents.common.agent_table import AGENTS, Kind, agents_where
from agents.common.folders import check_writable_folder
from agents.common.locations import POLICIES_DIR
from agents.common.seeds import TEST_SEED_START
from agents.common.tables import write_csv
from agents.evaluation.episode_tasks import EpisodeTask, rows_of
from agents.evaluation.runner import execute
from agents.policies import is_learned, policy_file, shipped_seed_runs

MIN_EPISODES = 300


class LeaderboardRow(TypedDict):
    """One agent's row of the history table (:func:`summarise_runs`): its rates with their 95 % intervals, and
    the interquartile mean of its failure over runs × layout blocks with its bootstrap interval."""

    agent: str
    runs: int
    episodes: int
    success_rate: float
    success_low: float
    success_high: float
    failure_rate: float
    failure_low: float
    failure_high: float
    collision_rate: float
    out_of_bounds_rate: float
    iqm_failure: float
    iqm_failure_low: float
    iqm_failure_high: float
    interval_over: str


class Improvement(TypedDict):
    """The probability that a learned agent's runs improve on a reactive agent, with its bootstrap interval."""

    learned: str
    reactive: str
    probability: float
    low: float
    high: float


def declared_as(agent: str, kind: Kind, *, privileged: bool | None = None) -> bool:
    """Whether ``agent`` is exactly the name of a declared agent of ``kind`` (a training seed's run name is
    none), privileged or not (either when None): read from the table when asked, so that an agent declared with
    :func:`~agents.common.agent_table.register_agent` is ranked as the shipped ones are."""
    entry = AGENTS.get(agent)
    return entry is not None and entry.kind == kind and privileged in (None, entry.privileged)


def leaderboard_runs(agents: Sequence[str], policies_dir: Path = POLICIES_DIR) -> dict[str, list[str]]:
    """Each agent's runs: a reactive agent is its own single run; a learned one is every shipped training
    seed (``ppo_flow@0``, ...). A learned agent without any is left out, with a message.

    Raises:
        ValueError: an unknown agent name.
    """
    runs: dict[str, list[str]] = {}
    for agent in agents:
        if declared_as(agent, "rule"):
            runs[agent] = [agent]
        elif declared_as(agent, "learned"):
            names = shipped_seed_runs(agent, policies_dir)
            if not names:
                print(
                    f"leaving out {agent}: no {Path(policies_dir) / agent}/seed_<k>.zip (flownav train --seeds)"
                )
                continue
            runs[agent] = names
        else:
            raise ValueError(
                f"agent must be one of {', '.join(agents_where(kind='rule') + agents_where(kind='learned'))}, "
                f"got {agent!r}"
            )
    return runs


def leaderboard_tasks(
    runs: dict[str, list[str]], episodes: int, policies_dir: Path = POLICIES_DIR
) -> list[EpisodeTask]:
    """Every run on the clean test layouts ``TEST_SEED_START ..``, layout by layout (so an interrupted
    flight leaves every agent with about the same layouts)."""
    names = [name for names in runs.values() for name in names]
    return [
        EpisodeTask(
            name,
            "clean",
            0.0,
            seed,
            policy=str(policy_file(name, directory=policies_dir)) if is_learned(name) else None,
        )
        for seed in range(TEST_SEED_START, TEST_SEED_START + episodes)
        for name in names
    ]


def summarise_runs(
    rows: Sequence[EpisodeRow], runs: dict[str, list[str]], layouts: list[int], block: int = LAYOUT_BLOCK
) -> list[LeaderboardRow]:
    """Per agent: runs, episodes, mean rates over runs with their 95 % intervals, and the IQM of the success
    rate over runs × layout blocks with its stratified-bootstrap interval."""
    outcomes = {agent: success_outcomes(rows, names, layouts) for agent, names in runs.items()}
    estimates = interval_estimates({agent: block_scores(o, block) for agent, o in outcomes.items()})
    table: list[LeaderboardRow] = []
    layout_set = set(layouts)
    for agent, names in runs.items():
        mine = [row for row in rows if row["agent"] in names and int(row["seed"]) in layout_set]
        n = outcomes[agent].size
        success = float(outcomes[agent].mean())
        if len(names) == 1:
            low, high = wilson_interval(int(outcomes[agent].sum()), n)
            interval = "layouts (Wilson)"
        else:
            low, high = runs_interval(outcomes[agent])
            interval = RUNS_INTERVAL
        table.append(
            {
                "agent": agent,
                "runs": len(names),
                "episodes": n,
                "success_rate": success,
                "success_low": low,
                "success_high": high,
                "failure_rate": 1.0 - success,
                "failure_low": 1.0 - high,
                "failure_high": 1.0 - low,
                "collision_rate": float(np.mean([bool(r["collision"]) for r in mine])),
                "out_of_bounds_rate": float(np.mean([bool(r["out_of_bounds"]) for r in mine])),
                "iqm_failure": 1.0 - estimates[agent]["iqm"],
                "iqm_failure_low": 1.0 - estimates[agent]["iqm_high"],
                "iqm_failure_high": 1.0 - estimates[agent]["iqm_low"],
                "interval_over": interval,
            }
        )
    return table


def improvements(
    rows: Sequence[EpisodeRow], runs: dict[str, list[str]], layouts: list[int], block: int = LAYOUT_BLOCK
) -> list[Improvement]:
    """P(learned run beats reactive agent) for every learned × reactive pair (straight left out), with its
    stratified-bootstrap interval."""
    learned = [agent for agent in runs if declared_as(agent, "learned")]
    reactive = [agent for agent in runs if declared_as(agent, "rule") and agent != "straight"]
    scores = {
        agent: block_scores(success_outcomes(rows, runs[agent], layouts), block)
        for agent in learned + reactive
    }
    result: list[Improvement] = []
    for x in learned:
        for y in reactive:
            point, low, high = probability_of_improvement(scores[x], scores[y])
            result.append({"learned": x, "reactive": y, "probability": point, "low": low, "high": high})
    return result


def against_best_reactive(
    table: Sequence[LeaderboardRow],
    rows: Sequence[EpisodeRow],
    runs: dict[str, list[str]],
    layouts: list[int],
) -> list[Comparison]:
    """Each learned agent but the privileged ones against the reactive agent (``straight`` aside) with the
    lowest failure rate, paired by layout (:func:`agents.analysis.paired.compare`)."""
    reactive = [r for r in table if declared_as(r["agent"], "rule") and r["agent"] != "straight"]
    learned = [r["agent"] for r in table if declared_as(r["agent"], "learned", privileged=False)]
    if not reactive or not learned:
        return []
    best = min(reactive, key=lambda r: r["failure_rate"])["agent"]
    failures = {a: episode_outcomes(rows, runs[a], layouts, "failure") for a in (best, *learned)}
    return [compare(a, failures[a], best, failures[best]) for a in learned]


@dataclass(frozen=True)
class Leaderboard:
    """What :func:`run_leaderboard` flew (or found, report-only) and scored in its folder, for its page.

    Attributes:
        folder: where the episodes, ``training_seeds.csv`` and the page lie.
        table: one row per agent (:func:`summarise_runs`).
        seed_rows: one row per (agent, training seed) with its rates (``training_seeds.csv``).
        gains: the probabilities of improvement (:func:`improvements`).
        layouts: the test layouts flown.
        block: layouts per block of the interquartile mean's bootstrap.
        against_best: each learned agent against the strongest reactive one (:func:`against_best_reactive`).
    """

    folder: Path
    table: list[LeaderboardRow]
    seed_rows: list[RunRates]
    gains: list[Improvement]
    layouts: list[int]
    block: int
    against_best: list[Comparison]


def run_leaderboard(
    agents: Sequence[str],
    out: Path,
    *,
    episodes: int = MIN_EPISODES,
    workers: int = 2,
    policies_dir: Path = POLICIES_DIR,
    report_only: bool = False,
    block: int = LAYOUT_BLOCK,
) -> Leaderboard:
    """Fly (unless ``report_only``) and score the leaderboard into ``out``: its episodes and
    ``training_seeds.csv``; returns what its page is written from
    (:func:`agents.pages.leaderboard_page.write_leaderboard_page`).

    Raises:
        ValueError: ``episodes`` below one block of layouts, ``workers`` below 1, an unknown agent, an
            unwritable ``out``, or a report with runs that have not flown every layout.
    """
    if episodes < block:  # checked before flying: the intervals over runs need whole blocks of layouts
        raise ValueError(
            f"--layouts must be >= {block} (one block of layouts for the intervals over runs), got {episodes}"
        )
    if workers < 1:
        raise ValueError(f"--workers must be >= 1, got {workers}")
    runs = leaderboard_runs(agents, policies_dir)
    out = Path(out)
    check_writable_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    csv_path = out / "leaderboard_episodes.csv"
    tasks = leaderboard_tasks(runs, episodes, policies_dir)
    if not report_only:
        execute(tasks, csv_path, workers=workers, description="leaderboard")
    rows = rows_of(tasks, read_records(csv_path)) if csv_path.is_file() else []
    layouts = list(range(TEST_SEED_START, TEST_SEED_START + episodes))
    table = summarise_runs(rows, runs, layouts, block)
    seed_rows = run_rates(rows)
    write_csv(
        out / "training_seeds.csv",
        [{k: (round(v, 4) if isinstance(v, float) else v) for k, v in r.items()} for r in seed_rows],
    )
    gains = improvements(rows, runs, layouts, block)
    return Leaderboard(
        out, table, seed_rows, gains, layouts, block, against_best_reactive(table, rows, runs, layouts)
    )
