"""Rates with their intervals: what a set of episode records says about an agent in a cell."""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Final, TypedDict

import numpy as np

from agents.analysis.episode_record import EpisodeRow


def wilson_interval(successes: int, trials: int, z: float = 1.959964) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion (95 % by default); (0, 1) for no trials."""
    if trials <= 0:
        return 0.0, 1.0
    p = successes / trials
    denominator = 1 + z**2 / trials
    centre = (p + z**2 / (2 * trials)) / denominator
    half = z * math.sqrt(p * (1 - p) / trials + z**2 / (4 * trials**2)) / denominator
    return max(0.0, centre - half), min(1.0, centre + half)


RUN_KEY: Final = "run"  # PooledRow's key (agents.analysis.episode_record)
"""A pooled row's own run (``ppo_flow@3``) where its ``agent`` names the pooled agent (``ppo_flow@all``)."""
BOOTSTRAP_REPS = 2000


CONFIDENCE = 0.95


def runs_and_layouts_interval(
    outcomes: np.ndarray, seed: int = 0, reps: int = BOOTSTRAP_REPS
) -> tuple[float, float]:
    """95 % interval of the success rate over runs and layouts: a two-level bootstrap that resamples runs, and
    layouts once per replicate for all its runs (every run flew the same layouts, so a hard layout is hard for
    all of them: resampling layouts per run would treat that shared difficulty as independent noise and make
    the interval too narrow). It carries both the spread between training runs and the layouts' sampling
    noise."""
    rng = np.random.default_rng(seed)
    runs, layouts = outcomes.shape
    chosen_runs = rng.integers(runs, size=(reps, runs, 1))
    chosen_layouts = rng.integers(layouts, size=(reps, 1, layouts))
    rates = outcomes[chosen_runs, chosen_layouts].mean(axis=(1, 2))
    tail = (1.0 - CONFIDENCE) / 2.0 * 100.0
    low, high = np.percentile(rates, [tail, 100.0 - tail])
    return float(low), float(high)


def failure_interval(rows: Sequence[EpisodeRow], seed: int = 0) -> tuple[float, float]:
    """95 % interval of the failure rate of ``rows``: Wilson over episodes for one run; for rows pooled from
    several training runs (their :data:`RUN_KEY`), a two-level bootstrap that resamples runs and their
    episodes, so that it carries the spread between training runs as well as the layouts' (where each run flew
    its own layouts, never narrower than Wilson's over the pooled episodes). Where every run flew
    the same layouts (a leaderboard), layouts are resampled once for all runs (:func:`runs_and_layouts_interval`,
    the same interval as the leaderboard's); where each flew its own (a sweep cell), each chosen run's own."""
    runs: dict[str, list[bool]] = {}
    layouts: dict[str, list[int]] = {}
    for row in rows:
        runs.setdefault(str(row.get(RUN_KEY, "")), []).append(not bool(row["success"]))
        layouts.setdefault(str(row.get(RUN_KEY, "")), []).append(int(row.get("seed", -1)))
    failures = sum(sum(values) for values in runs.values())
    n = sum(len(values) for values in runs.values())
    if len(runs) < 2:
        return wilson_interval(failures, n)
    order = {name: np.argsort(seeds, kind="stable") for name, seeds in layouts.items()}
    shared = [sorted(seeds) for seeds in layouts.values()]
    if all(seeds == shared[0] for seeds in shared) and len(set(shared[0])) == len(shared[0]):
        successes = np.array([1.0 - np.asarray(runs[name], float)[order[name]] for name in runs])
        low, high = runs_and_layouts_interval(successes, seed=seed)
        return 1.0 - high, 1.0 - low
    sizes = np.array([len(values) for values in runs.values()])
    padded = np.zeros((len(runs), sizes.max()))
    for index, values in enumerate(runs.values()):
        padded[index, : len(values)] = values
    rng = np.random.default_rng(seed)
    chosen = rng.integers(len(runs), size=(BOOTSTRAP_REPS, len(runs)))
    chosen_sizes = sizes[chosen]
    picks = np.floor(rng.random((BOOTSTRAP_REPS, len(runs), sizes.max())) * chosen_sizes[..., None]).astype(
        int
    )
    inside = np.arange(sizes.max()) < chosen_sizes[..., None]
    drawn = padded[chosen[..., None], picks] * inside
    rates = drawn.sum(axis=(1, 2)) / inside.sum(axis=(1, 2))
    low, high = np.percentile(rates, [2.5, 97.5])
    # With few episodes per run the percentile bootstrap is too narrow (all successes give [0, 0]): it is
    # never allowed to claim more than the episodes' own binomial noise, Wilson's interval, allows.
    wilson_low, wilson_high = wilson_interval(failures, n)
    return float(min(low, wilson_low)), float(max(high, wilson_high))


class CellSummary(TypedDict):
    """One row of :func:`summarise`: an (agent, factor, level) cell's episodes, rates and 95 % intervals."""

    agent: str
    factor: str
    level: float
    episodes: int
    collisions: int
    collision_rate: float
    ci_low: float
    ci_high: float
    success_rate: float
    success_ci_low: float
    success_ci_high: float
    median_progress_m: float
    median_min_clearance_m: float
    out_of_bounds: int
    failure_rate: float
    failure_ci_low: float
    failure_ci_high: float


def summarise(rows: Iterable[EpisodeRow]) -> list[CellSummary]:
    """Per (agent, factor, level): episodes, collisions, collision rate with its Wilson 95 % interval,
    success rate with its interval, failure rate with its interval (:func:`failure_interval`: over training
    runs and layouts where the rows pool several runs), episodes out of bounds, and medians of progress and
    clearance.

    A failure is every episode that did not reach the goal: a collision, leaving the course (out of bounds)
    or the time limit. Collisions alone can fall while failures rise (a drone that leaves the course sideways
    collides with nothing), so the failure rate is the headline and the collision rate one of its causes.
    """
    groups: dict[tuple[str, str, float], list[EpisodeRow]] = {}
    for row in rows:
        groups.setdefault((row["agent"], row["factor"], float(row["level"])), []).append(row)
    table: list[CellSummary] = []
    for (agent, factor, level), members in sorted(groups.items()):
        n = len(members)
        collisions = sum(bool(m["collision"]) for m in members)
        successes = sum(bool(m["success"]) for m in members)
        out_of_bounds = sum(bool(m["out_of_bounds"]) for m in members)
        low, high = wilson_interval(collisions, n)
        failure_low, failure_high = failure_interval(members)
        success_low, success_high = 1.0 - failure_high, 1.0 - failure_low
        table.append(
            {
                "agent": agent,
                "factor": factor,
                "level": level,
                "episodes": n,
                "collisions": collisions,
                "collision_rate": collisions / n,
                "ci_low": low,
                "ci_high": high,
                "success_rate": successes / n,
                "success_ci_low": success_low,
                "success_ci_high": success_high,
                "median_progress_m": float(np.median([m["progress_m"] for m in members])),
                "median_min_clearance_m": float(np.median([m["min_clearance_m"] for m in members])),
                "out_of_bounds": out_of_bounds,
                "failure_rate": (n - successes) / n,
                "failure_ci_low": failure_low,
                "failure_ci_high": failure_high,
            }
        )
    return table


SUMMARY_COLUMNS = ("agent", "factor", "level", "episodes")
"""The leading columns of :func:`format_summary`, the ones a caller may omit; the rates always show."""


def format_summary(table: Sequence[CellSummary], *, omit: Iterable[str] = ()) -> str:
    """The summary as a Markdown table.

    Args:
        table: rows of :func:`summarise`.
        omit: leading columns to leave out (of :data:`SUMMARY_COLUMNS`), such as a ``factor`` and ``level``
            that are the same in every row.

    Raises:
        ValueError: ``omit`` names something that is not one of those columns.
    """
    omit = set(omit)
    if not omit <= set(SUMMARY_COLUMNS):
        raise ValueError(f"omit must name columns of {', '.join(SUMMARY_COLUMNS)}, got {sorted(omit)}")
    leading = [name for name in SUMMARY_COLUMNS if name not in omit]
    header = "".join(f"| {name} " for name in leading) + (
        "| failure rate [95 % CI] | success rate [95 % CI] | collision rate [95 % CI] | out of bounds | "
        "median progress (m) |"
    )
    lines = [header, "|" + "---|" * (len(leading) + 5)]
    for r in table:
        cells = {
            "agent": r["agent"],
            "factor": r["factor"],
            "level": f"{r['level']:g}",
            "episodes": r["episodes"],
        }
        lines.append(
            "".join(f"| {cells[name]} " for name in leading)
            + f"| {r['failure_rate']:.2f} [{r['failure_ci_low']:.2f}, {r['failure_ci_high']:.2f}] | "
            f"{r['success_rate']:.2f} [{r['success_ci_low']:.2f}, {r['success_ci_high']:.2f}] | "
            f"{r['collision_rate']:.2f} [{r['ci_low']:.2f}, {r['ci_high']:.2f}] | "
            f"{r['out_of_bounds'] / r['episodes']:.2f} | {r['median_progress_m']:.1f} |"
        )
    return "\n".join(lines)


def failure(rows: Sequence[EpisodeRow]) -> tuple[float, float, float, int]:
    """Failure rate, its 95 % interval (over training runs too where the rows pool several:
    :func:`failure_interval`) and the episodes."""
    n = len(rows)
    failures = sum(not bool(r["success"]) for r in rows)
    low, high = failure_interval(rows)
    return failures / n, low, high, n


def runs_failure(successes: np.ndarray) -> tuple[float, float, float]:
    """Failure over runs × layouts (``successes``: a row of 0/1 per run, every run on the same layouts) and its
    95 % interval: a two-level bootstrap from two runs on (as ``flownav ablation``), Wilson's for one run."""
    if len(successes) > 1:
        low, high = runs_and_layouts_interval(successes)
    else:
        low, high = wilson_interval(int(successes.sum()), successes.size)
    return float(1 - successes.mean()), 1 - high, 1 - low
