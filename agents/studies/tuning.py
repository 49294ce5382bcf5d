"""Tunes a reactive agent's parameters on training seeds only, and reports the tuning curve.

``flownav tune --agent {bee,bee_robust,vfh}`` runs the two-stage study of :mod:`.tuning_study` (TPE search on
shared layouts, then the finalists and the defaults on fresh ones) and writes to its output folder:

* ``episodes.csv``: every episode, appended as it ends; running the same command again resumes;
* ``tuning.md``: the command, search space, budget, the finalists with their intervals, the winner, and
  whether it is clearly better than the defaults;
* ``best.json``: the winner's parameters (keyword arguments of the agent's dataclass);
* ``tuning_curve.png``: each trial's search failure rate with the best so far, and the finalists' final rates.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from agents.analysis.paired import Comparison, compare
from agents.analysis.records import start_new_file
from agents.common.agent_entry import SearchRange
from agents.common.folders import check_writable_folder
from agents.pages.wording import render_report
from agents.policies.registry import search_space
from agents.studies.perf.report_kit import saved_figure
from agents.studies.tuning_study import (
    MIN_FINAL_EPISODES,
    SAMPLER_SEED,
    Budget,
    TrialResult,
    check_agent,
    default_params,
    run_final,
    run_search,
)


@dataclass(frozen=True)
class TuningResult:
    """A finished study: every search trial in order, the finalists best first (final-stage summaries), the
    winner (the first finalist) and the Markdown report's lines."""

    agent: str
    search: list[TrialResult]
    finals: list[TrialResult]
    lines: list[str] = field(default_factory=list)

    @property
    def winner(self) -> TrialResult:
        return self.finals[0]

    @property
    def defaults(self) -> TrialResult:
        """The defaults' final-stage result (always a finalist)."""
        return next(trial for trial in self.finals if trial.number == 0)


def command_line(agent: str, budget: Budget, env_id: str, out: Path) -> str:
    """The ``flownav tune`` call that reproduces a study (``--workers`` changes speed, not results)."""
    return (
        f"flownav tune --agent {agent} --trials {budget.trials} --search-episodes {budget.search_episodes} "
        f"--finalists {budget.finalists} --final-episodes {budget.final_episodes} --env-id {env_id} "
        f"--out {out}"
    )


def tune(
    agent: str,
    out: Path,
    budget: Budget | None = None,
    *,
    env_id: str = "FlowNav-v0",
    env_kwargs: Mapping[str, object] | None = None,
    workers: int = 2,
    overwrite: bool = False,
    sampler_seed: int = SAMPLER_SEED,
    final_minimum: int = MIN_FINAL_EPISODES,
) -> TuningResult:
    """Run (or resume) the study for ``agent`` and write its outputs to ``out``.

    Args:
        agent: a tunable agent (:func:`~agents.policies.registry.tunable_agents`: one with a ``search_space``).
        out: output folder; its ``episodes.csv`` is resumed when it holds episodes of the same settings.
        budget: trials, episodes per trial, finalists, final episodes (default: :class:`Budget`'s).
        env_id: env to tune on.
        env_kwargs: env settings on top of the agent's own (tests shrink the camera; not on the command line).
        workers: local processes flying episodes in parallel.
        overwrite: move an existing ``episodes.csv`` to ``episodes.csv.bak-<time>`` first (nothing is deleted).
        sampler_seed: the TPE sampler's seed; the same seed and CSV give the same study.
        final_minimum: the fewest final episodes accepted; only tests and smoke runs lower it.

    Raises:
        ValueError: an unknown agent, a bad budget or worker count (the message names the option and its
            range), or a CSV holding these episodes flown with other settings.
        EpisodesInterrupted: Ctrl-C; the episodes flown so far are kept and the same call resumes.
    """
    check_agent(agent)
    budget = budget or Budget()
    budget.check(final_minimum)
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"--workers must be an integer >= 1, got {workers!r}")
    out = Path(out)
    check_writable_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    csv_path = out / "episodes.csv"
    if overwrite and (moved := start_new_file(csv_path)) is not None:
        print(f"--overwrite: moved {csv_path} to {moved}")
    env_kwargs = dict(env_kwargs or {})
    search = run_search(
        agent,
        budget,
        csv_path,
        env_id=env_id,
        env_kwargs=env_kwargs,
        workers=workers,
        sampler_seed=sampler_seed,
    )
    finals = run_final(agent, budget, search, csv_path, env_id=env_id, env_kwargs=env_kwargs, workers=workers)
    result = TuningResult(agent, search, finals)
    text = report_text(result, budget, command_line(agent, budget, env_id, out), env_kwargs, sampler_seed)
    (out / "tuning.md").write_text(text)
    (out / "best.json").write_text(json.dumps(result.winner.params, indent=2) + "\n")
    plot_tuning_curve(result, out / "tuning_curve.png")
    return dataclasses.replace(result, lines=text.split("\n")[:-1])


def comparison(result: TuningResult) -> Comparison | None:
    """The winner against the defaults on the final layouts both flew, paired by layout
    (:func:`agents.analysis.paired.compare`); None where the defaults won."""
    if result.winner.number == 0:
        return None
    winner, defaults = (np.array([trial.failures]) for trial in (result.winner, result.defaults))
    return compare("winner", winner, "defaults", defaults)


@dataclass(frozen=True)
class TuningValues:
    """Every value ``tuning.md`` words (``templates/tuning.md.j2``): the study (``r``) and its budget, how to
    rerun it, the agent's search space and defaults, the layouts of each stage, each search trial's failure rate
    by number, and the winner against the defaults (None where the defaults won)."""

    r: TuningResult
    budget: Budget
    command: str
    env_kwargs: dict[str, object]
    sampler_seed: int
    space: dict[str, SearchRange]
    defaults: dict[str, float]
    search_seeds: range
    final_seeds: range
    search_rate: dict[int, float]
    winner_params: str
    comparison: Comparison | None


def report_text(
    result: TuningResult, budget: Budget, command: str, env_kwargs: Mapping[str, object], sampler_seed: int
) -> str:
    """``tuning.md``: enough to rerun the study and to judge its winner."""
    search_seeds, final_seeds = budget.layout_seeds()
    values = TuningValues(
        r=result,
        budget=budget,
        command=command,
        env_kwargs=dict(env_kwargs),
        sampler_seed=sampler_seed,
        space=search_space(result.agent),
        defaults=default_params(result.agent),
        search_seeds=search_seeds,
        final_seeds=final_seeds,
        search_rate={trial.number: trial.summary["failure_rate"] for trial in result.search},
        winner_params=json.dumps(result.winner.params),
        comparison=comparison(result),
    )
    return render_report("tuning.md.j2", values)


def plot_tuning_curve(result: TuningResult, path: Path) -> None:
    """The search's failure rate per trial with the best so far (how much more searching could still give),
    beside the finalists' final failure rates with their intervals (how much of that survives fresh layouts)."""
    numbers = [trial.number for trial in result.search]
    rates = [trial.summary["failure_rate"] for trial in result.search]
    best_so_far = np.minimum.accumulate(rates)
    finalist_numbers = {trial.number for trial in result.finals}
    with saved_figure(path, (9.0, 3.4), dpi=120) as fig:
        curve, finals = fig.subplots(1, 2, gridspec_kw={"width_ratios": [2, 1]}, sharey=True)
        curve.plot(numbers, rates, "o", color="tab:blue", alpha=0.6, label="trial")
        curve.step(numbers, best_so_far, where="post", color="k", label="best so far")
        chosen = [(n, r) for n, r in zip(numbers, rates, strict=True) if n in finalist_numbers]
        curve.plot(*zip(*chosen, strict=True), "o", mfc="none", mec="tab:red", ms=10, label="finalist")
        curve.set_xlabel("trial (0 = defaults)")
        curve.set_ylabel("failure rate")
        curve.set_ylim(0, 1)
        curve.set_title(f"{result.agent}: search layouts", fontsize=9)
        curve.grid(alpha=0.3)
        curve.legend(fontsize=8)
        labels = [f"#{trial.number}" + (" def." if trial.number == 0 else "") for trial in result.finals]
        values = [trial.summary["failure_rate"] for trial in result.finals]
        errors = [
            [v - t.summary["failure_ci_low"] for v, t in zip(values, result.finals, strict=True)],
            [t.summary["failure_ci_high"] - v for v, t in zip(values, result.finals, strict=True)],
        ]
        colours = ["tab:red" if i == 0 else "tab:blue" for i in range(len(values))]
        finals.bar(labels, values, yerr=errors, capsize=4, color=colours, alpha=0.7)
        finals.set_title("finalists: fresh layouts (95 % CI; winner red)", fontsize=9)
        finals.grid(alpha=0.3, axis="y")
