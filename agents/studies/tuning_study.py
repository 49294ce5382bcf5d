"""The tuning study behind ``flownav tune``: what is searched, on which layouts, and how a winner is chosen.

Two stages, both on training seeds only (:mod:`agents.common.seeds`), so that no layout a report is scored on
ever helped pick a gain:

* **search**: an optuna TPE study over the agent's search space (its ``search_space`` in ``configs/agents.yaml``,
  :func:`~agents.policies.registry.search_space`), seeded so it is reproducible. Every
  trial flies the same layouts (common random numbers: trials differ by their gains, not by their luck with
  layouts), scored by failure rate, ties broken by fewer collisions. Trial 0 is the agent's current defaults,
  so the search starts from what is shipped and the report can compare against it.
* **final**: the best few trials, and always the defaults, fly the same fresh layouts, disjoint from the
  search's. The best search score is biased low (the winner's curse: with many trials, one is lucky), so the
  winner is chosen on the final layouts alone.

Resuming: the study lives in memory and is rebuilt on every run by replaying the same ask/tell sequence; a
seeded TPE sampler proposes the same gains from the same history, and trials whose episodes are already in
the CSV are scored from it without flying (:func:`agents.evaluation.runner.execute` skips them).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from agents.analysis.records import read_records
from agents.analysis.statistics import CellSummary, summarise
from agents.common.seeds import VALIDATION_SEED_START
from agents.evaluation.episode_tasks import EpisodeTask, rows_of
from agents.evaluation.runner import execute
from agents.policies.registry import agent_class, search_space, tunable_agents

MIN_FINAL_EPISODES = 100  # fewer leaves the finalists' intervals too wide to tell them apart
SEARCH_SEED_START = 0  # search layouts first, final layouts right after: both far below the validation seeds
SAMPLER_SEED = 0


@dataclass(frozen=True)
class Budget:
    """How many episodes the study may fly; the defaults are ``flownav tune``'s."""

    trials: int = 40
    search_episodes: int = 30
    finalists: int = 4
    final_episodes: int = 150

    def check(self, final_minimum: int = MIN_FINAL_EPISODES) -> None:
        """Refuse a budget that cannot give a trustworthy answer or would reach the validation seeds.

        ``final_minimum`` is lowered only by tests and smoke runs: a real winner needs at least
        :data:`MIN_FINAL_EPISODES` final episodes.

        Raises:
            ValueError: naming the option, its value and its allowed range.
        """
        for option, value in (("--trials", self.trials), ("--search-layouts", self.search_episodes)):
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{option} must be an integer >= 1, got {value!r}")
        if isinstance(self.finalists, bool) or not isinstance(self.finalists, int):
            raise ValueError(f"--finalists must be an integer, got {self.finalists!r}")
        if not 1 <= self.finalists <= self.trials:
            raise ValueError(f"--finalists must be in [1, --trials = {self.trials}], got {self.finalists}")
        if isinstance(self.final_episodes, bool) or not isinstance(self.final_episodes, int):
            raise ValueError(f"--final-layouts must be an integer, got {self.final_episodes!r}")
        if self.final_episodes < final_minimum:
            raise ValueError(f"--final-layouts must be >= {final_minimum}, got {self.final_episodes}")
        end = SEARCH_SEED_START + self.search_episodes + self.final_episodes
        if end > VALIDATION_SEED_START:
            raise ValueError(
                "--search-layouts + --final-layouts must stay within the training seeds "
                f"[{SEARCH_SEED_START}, {VALIDATION_SEED_START}), got {self.search_episodes} + "
                f"{self.final_episodes} = {self.search_episodes + self.final_episodes} layouts"
            )

    def layout_seeds(self) -> tuple[range, range]:
        """The search layouts and the final layouts: consecutive training seeds, disjoint."""
        final_start = SEARCH_SEED_START + self.search_episodes
        return range(SEARCH_SEED_START, final_start), range(final_start, final_start + self.final_episodes)


@dataclass(frozen=True)
class TrialResult:
    """One trial's gains and what its episodes came to in one stage (a row of
    :func:`~agents.analysis.statistics.summarise`: failure, success, collision rates with their intervals)."""

    number: int
    params: dict[str, float]
    summary: CellSummary
    # Failure (1) or not per layout, in seed order: what two finalists on the same layouts are paired by.
    failures: tuple[float, ...] = ()

    def rank(self) -> tuple[float, float, int]:
        """Fewer failures first, then fewer collisions, then the earlier trial (the defaults win a tie)."""
        return (self.summary["failure_rate"], self.summary["collision_rate"], self.number)


def check_agent(agent: str) -> None:
    """Raises: ValueError: ``agent`` has no search space (the message lists the tunable agents)."""
    if agent not in tunable_agents():
        raise ValueError(f"--agent must be one of {', '.join(tunable_agents())}, got {agent!r}")


def default_params(agent: str) -> dict[str, float]:
    """The agent's current dataclass defaults for the searched parameters: trial 0, the baseline to beat.

    Raises:
        ValueError: ``agent`` is not tunable, or a searched gain's default is not a number.
    """
    check_agent(agent)
    fields = dataclasses.fields(agent_class(agent))
    defaults = {item.name: item.default for item in fields if isinstance(item.default, int | float)}
    space = search_space(agent)
    not_numbers = [name for name in space if name not in defaults]
    if not_numbers:
        raise ValueError(
            f"agent {agent!r} search_space names {', '.join(not_numbers)}, whose defaults are not numbers; "
            f"numeric gains: {', '.join(defaults)}"
        )
    return {name: defaults[name] for name in space}


def distributions(agent: str) -> dict[str, Any]:
    """The agent's search space as optuna distributions (integers where the field's default is one)."""
    # optuna is slow to import and only the search needs it.
    from optuna.distributions import FloatDistribution, IntDistribution

    defaults = default_params(agent)
    return {
        name: (
            IntDistribution(int(low), int(high), log=log)
            if isinstance(defaults[name], int)
            else FloatDistribution(low, high, log=log)
        )
        for name, (low, high, log) in search_space(agent).items()
    }


def trial_tasks(
    agent: str,
    stage: str,
    number: int,
    params: Mapping[str, float],
    seeds: range,
    env_id: str,
    env_kwargs: Mapping[str, object],
) -> list[EpisodeTask]:
    """A trial's episodes in one stage: ``factor`` names the stage and ``level`` the trial, so (agent, factor,
    level, seed) is unique per trial and two trials never share a CSV row."""
    gains = tuple(sorted(params.items()))
    kwargs = tuple(sorted(env_kwargs.items()))
    return [
        EpisodeTask(agent, stage, float(number), seed, env_id, kwargs, bee_params=gains) for seed in seeds
    ]


def stage_summary(tasks: list[EpisodeTask], csv_path: Path) -> CellSummary:
    """The summary row of these tasks' episodes (only theirs: the CSV may hold other trials and stages).

    Raises:
        ValueError: an episode is missing (the CSV was edited while running).
    """
    table = summarise(rows_of(tasks, read_records(csv_path)))
    if len(table) != 1 or table[0]["episodes"] != len(tasks):
        found = table[0]["episodes"] if table else 0
        raise ValueError(
            f"{csv_path} holds {found} of the {len(tasks)} episodes just flown; was it edited, or is another run writing to it?"
        )
    return table[0]


def run_search(
    agent: str,
    budget: Budget,
    csv_path: Path,
    *,
    env_id: str,
    env_kwargs: Mapping[str, object],
    workers: int,
    sampler_seed: int = SAMPLER_SEED,
) -> list[TrialResult]:
    """The search stage: ``budget.trials`` TPE trials in order, each flown (or read back) before the next is
    asked for, so a re-run replays the same study; returns every trial with its search-stage summary."""
    # optuna is slow to import and only the search needs it.
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)  # one line per trial would bury the progress bars
    study = optuna.create_study(direction="minimize", sampler=optuna.samplers.TPESampler(seed=sampler_seed))
    study.enqueue_trial(default_params(agent))
    space = distributions(agent)
    seeds, _ = budget.layout_seeds()
    results = []
    for _ in range(budget.trials):
        trial = study.ask(space)
        tasks = trial_tasks(agent, "search", trial.number, trial.params, seeds, env_id, env_kwargs)
        description = f"{agent} search trial {trial.number + 1}/{budget.trials}"
        execute(tasks, csv_path, workers=workers, description=description)
        summary = stage_summary(tasks, csv_path)
        # Failure rate first; the collision rate, scaled below one failure's step, only breaks ties.
        tie_break = summary["collision_rate"] / (budget.search_episodes + 1)
        study.tell(trial, summary["failure_rate"] + tie_break)
        results.append(TrialResult(trial.number, dict(trial.params), summary))
    return results


def run_final(
    agent: str,
    budget: Budget,
    search: list[TrialResult],
    csv_path: Path,
    *,
    env_id: str,
    env_kwargs: Mapping[str, object],
    workers: int,
) -> list[TrialResult]:
    """The final stage: the ``budget.finalists`` best search trials, plus the defaults (trial 0) if they are
    not among them, each on the same fresh layouts; returns their final-stage results, best first."""
    chosen = sorted(search, key=TrialResult.rank)[: budget.finalists]
    if all(trial.number != 0 for trial in chosen):
        chosen.append(search[0])
    _, seeds = budget.layout_seeds()
    tasks = {
        trial.number: trial_tasks(agent, "final", trial.number, trial.params, seeds, env_id, env_kwargs)
        for trial in chosen
    }
    all_tasks = [task for trial in chosen for task in tasks[trial.number]]
    execute(all_tasks, csv_path, workers=workers, description=f"{agent} final {len(chosen)} finalists")
    flown = {
        (float(r["level"]), int(r["seed"])): float(not r["success"])
        for r in rows_of(all_tasks, read_records(csv_path))
    }
    finals = [
        TrialResult(
            t.number,
            t.params,
            stage_summary(tasks[t.number], csv_path),
            tuple(flown[(float(t.number), seed)] for seed in seeds),
        )
        for t in chosen
    ]
    return sorted(finals, key=TrialResult.rank)
