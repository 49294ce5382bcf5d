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
from typing import Any

import numpy as np

from agents.common.folders import check_writable_folder
from agents.evaluation.paired import compare
from agents.evaluation.records import start_new_file
from agents.studies.tuning_study import (
    MIN_FINAL_EPISODES,
    SAMPLER_SEED,
    SEARCH_SPACES,
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
    env_kwargs: Mapping[str, Any] | None = None,
    workers: int = 2,
    overwrite: bool = False,
    sampler_seed: int = SAMPLER_SEED,
    final_minimum: int = MIN_FINAL_EPISODES,
) -> TuningResult:
    """Run (or resume) the study for ``agent`` and write its outputs to ``out``.

    Args:
        agent: one of :data:`~agents.studies.tuning_study.TUNABLE_AGENTS`.
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
    lines = report_lines(result, budget, command_line(agent, budget, env_id, out), env_kwargs, sampler_seed)
    (out / "tuning.md").write_text("\n".join(lines) + "\n")
    (out / "best.json").write_text(json.dumps(result.winner.params, indent=2) + "\n")
    plot_tuning_curve(result, out / "tuning_curve.png")
    return dataclasses.replace(result, lines=lines)


def _interval(summary: Mapping[str, Any], rate: str, low: str, high: str) -> str:
    return f"{summary[rate]:.2f} [{summary[low]:.2f}, {summary[high]:.2f}]"


def _failure(summary: Mapping[str, Any]) -> str:
    return _interval(summary, "failure_rate", "failure_ci_low", "failure_ci_high")


def verdict(result: TuningResult) -> str:
    """Whether the winner fails less than the defaults on the final layouts both flew, by the paired test
    (:func:`agents.evaluation.paired.compare`)."""
    winner = result.winner
    if winner.number == 0:
        return (
            "The defaults (trial 0) won the final stage: no trial beat them on the fresh layouts; keep them."
        )
    found = compare("winner", np.array([winner.failures]), "defaults", np.array([result.defaults.failures]))
    paired = (
        f"paired by layout, winner − defaults = {found.difference:+.3f} [{found.low:+.3f}, {found.high:+.3f}]"
    )
    if found.fails_less == "winner":
        return f"The winner (trial {winner.number}) fails less than the defaults on the same final layouts ({paired})."
    return (
        f"The winner (trial {winner.number}) is not shown to fail less than the defaults ({paired}), so its "
        "margin may be luck of the layouts."
    )


def report_lines(
    result: TuningResult,
    budget: Budget,
    command: str,
    env_kwargs: Mapping[str, Any],
    sampler_seed: int,
) -> list[str]:
    """``tuning.md``: enough to rerun the study and to judge its winner."""
    space = SEARCH_SPACES[result.agent]
    defaults = default_params(result.agent)
    search_seeds, final_seeds = budget.layout_seeds()
    episodes = len(result.search) * len(search_seeds) + len(result.finals) * len(final_seeds)
    names = list(space)
    lines = [
        f"# Tuning {result.agent} on training seeds",
        "",
        f"Command: `{command}`" + (f" (API call with env_kwargs `{dict(env_kwargs)}`)" if env_kwargs else ""),
        "",
        "## Search space",
        "",
        "| parameter | low | high | scale | default |",
        "|---|---|---|---|---|",
        *(
            f"| {name} | {low:g} | {high:g} | {'log' if log else 'linear'} | {defaults[name]:g} |"
            for name, (low, high, log) in space.items()
        ),
        "",
        "## Budget",
        "",
        f"- Search: optuna TPE (seed {sampler_seed}), {len(result.search)} trials, trial 0 the defaults; each "
        f"trial flies the same {len(search_seeds)} training layouts (seeds {search_seeds.start}-"
        f"{search_seeds.stop - 1}); objective: failure rate, ties broken by collision rate.",
        f"- Final: the best {budget.finalists} trials, and the defaults if not among them ({len(result.finals)} "
        "finalists), each "
        f"fly the same {len(final_seeds)} fresh training layouts (seeds {final_seeds.start}-"
        f"{final_seeds.stop - 1}); the winner is the lowest failure rate there.",
        f"- Episodes: {episodes}.",
        "",
        "## Finalists (final layouts)",
        "",
        "| trial | search failure | failure [95 % CI] | success [95 % CI] | collision [95 % CI] | "
        "out of bounds | " + " | ".join(names) + " |",
        "|---|---|---|---|---|---|" + "---|" * len(names),
    ]
    search_rate = {trial.number: trial.summary["failure_rate"] for trial in result.search}
    for trial in result.finals:
        s = trial.summary
        label = f"{trial.number}" + (" (defaults)" if trial.number == 0 else "")
        lines.append(
            f"| {label} | {search_rate[trial.number]:.2f} | {_failure(s)} | "
            f"{_interval(s, 'success_rate', 'success_ci_low', 'success_ci_high')} | "
            f"{_interval(s, 'collision_rate', 'ci_low', 'ci_high')} | {s['out_of_bounds'] / s['episodes']:.2f} | "
            + " | ".join(f"{trial.params[name]:.4g}" for name in names)
            + " |"
        )
    lines += [
        "",
        f"Winner: trial {result.winner.number}, `{json.dumps(result.winner.params)}` (in `best.json`).",
        "",
        verdict(result),
        "",
        "## Search trials",
        "",
        "| trial | failure | collision | " + " | ".join(names) + " |",
        "|---|---|---|" + "---|" * len(names),
        *(
            f"| {t.number} | {t.summary['failure_rate']:.2f} | {t.summary['collision_rate']:.2f} | "
            + " | ".join(f"{t.params[name]:.4g}" for name in names)
            + " |"
            for t in result.search
        ),
    ]
    return lines


def plot_tuning_curve(result: TuningResult, path: Path) -> None:
    """The search's failure rate per trial with the best so far (how much more searching could still give),
    beside the finalists' final failure rates with their intervals (how much of that survives fresh layouts)."""
    # matplotlib takes a second to import: only the writers that draw a figure load it.
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    numbers = [trial.number for trial in result.search]
    rates = [trial.summary["failure_rate"] for trial in result.search]
    best, best_so_far = float("inf"), []
    for rate in rates:
        best = min(best, rate)
        best_so_far.append(best)
    finalist_numbers = {trial.number for trial in result.finals}
    fig, (curve, finals) = plt.subplots(
        1, 2, figsize=(9.0, 3.4), gridspec_kw={"width_ratios": [2, 1]}, sharey=True
    )
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
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
