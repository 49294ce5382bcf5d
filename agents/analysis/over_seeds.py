"""Agents over training seeds: per-run rates, interval estimates over runs and layouts, and the probability
that a learned agent improves on a reactive one.

A learned agent is several independent training runs (``ppo_flow@0`` ... ``ppo_flow@4``), each flown on the
same test layouts; a reactive agent is one deterministic "run". Following Agarwal et al. (2021, "Deep RL at
the Edge of the Statistical Precipice") and their ``rliable`` library, scores form a matrix of runs × tasks.
FlowNav's clean cell is one task, so its layouts are cut into blocks of :data:`LAYOUT_BLOCK` consecutive test
layouts, each block a task: the stratified bootstrap resamples runs within each block, and the probability
of improvement compares runs block by block.

Scores are success rates (higher is better, as rliable expects); a failure rate is one minus a success rate,
since an episode fails exactly when it does not reach the goal.
"""

from __future__ import annotations

import contextlib
import warnings
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from typing import TypedDict

import numpy as np

from agents.analysis.episode_record import EPISODE_OUTCOMES, EpisodeRow, episode_outcome
from agents.analysis.records import layout_seed
from agents.analysis.statistics import BOOTSTRAP_REPS, CONFIDENCE
from agents.common.agent_table import split_agent_name

LAYOUT_BLOCK = 30
# rliable's probability of improvement runs a Mann-Whitney test per block in every replicate: fewer of them.
IMPROVEMENT_REPS = 1000


@contextlib.contextmanager
def _seeded_global_numpy(seed: int) -> Iterator[None]:
    """Seed NumPy's global generator for the block, then restore its state.

    rliable's ``StratifiedBootstrap`` draws its run indices from ``np.random`` itself, whatever
    ``random_state`` it is given, so without this the same episodes gave other intervals on every report.
    """
    state = np.random.get_state()  # noqa: NPY002 (rliable reads the legacy global generator)
    np.random.seed(seed)  # noqa: NPY002
    try:
        yield
    finally:
        np.random.set_state(state)  # noqa: NPY002


def _rliable_estimates(
    scores: Mapping[str, np.ndarray | tuple[np.ndarray, np.ndarray]],
    func: Callable[..., np.ndarray | float],
    seed: int,
    reps: int,
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """rliable's point estimates and stratified-bootstrap intervals, the same for the same inputs and seed."""
    from rliable import library  # heavy (it brings arch and scipy.stats): only a report that needs it pays

    with warnings.catch_warnings(), _seeded_global_numpy(seed):
        # arch (under rliable) announces that it will stop taking a RandomState, which rliable passes it.
        warnings.simplefilter("ignore", FutureWarning)
        return library.get_interval_estimates(
            dict(scores),
            func,
            reps=reps,
            confidence_interval_size=CONFIDENCE,
            random_state=np.random.RandomState(seed),
        )


class RunRates(TypedDict):
    """One run's rates over its episodes (:func:`run_rates`): its training seed is "" for a reactive agent."""

    agent: str
    train_seed: int | str
    episodes: int
    success_rate: float
    failure_rate: float
    collision_rate: float
    out_of_bounds_rate: float


def run_rates(rows: Iterable[EpisodeRow]) -> list[RunRates]:
    """One row per run (agent name, with its training seed for a learned agent): episodes and the success,
    failure, collision and out-of-bounds rates over them; sorted by agent, then training seed."""
    groups: dict[str, list[EpisodeRow]] = {}
    for row in rows:
        groups.setdefault(row["agent"], []).append(row)
    table: list[RunRates] = []
    for name, members in groups.items():
        agent, train_seed = split_agent_name(name)
        n = len(members)
        successes = sum(bool(m["success"]) for m in members)
        table.append(
            {
                "agent": agent,
                "train_seed": "" if train_seed is None else train_seed,
                "episodes": n,
                "success_rate": successes / n,
                "failure_rate": (n - successes) / n,
                "collision_rate": sum(bool(m["collision"]) for m in members) / n,
                "out_of_bounds_rate": sum(bool(m["out_of_bounds"]) for m in members) / n,
            }
        )
    return sorted(
        table, key=lambda r: (r["agent"], -1 if isinstance(r["train_seed"], str) else r["train_seed"])
    )


def success_outcomes(rows: Iterable[EpisodeRow], runs: Sequence[str], layouts: Sequence[int]) -> np.ndarray:
    """Success (1) or failure (0) of every run on every layout: (runs, layouts).

    Raises:
        ValueError: a run that has not flown one of the layouts (its name and the first missing seed).
    """
    return episode_outcomes(rows, runs, layouts, "success")


def episode_outcomes(
    rows: Iterable[Mapping[str, object]], runs: Sequence[str], layouts: Sequence[int], outcome: str
) -> np.ndarray:
    """Whether each run's episode on each layout had ``outcome`` (1) or not (0): (runs, layouts). ``outcome``
    is one of :data:`~flownav_env.task.EPISODE_OUTCOMES` (exclusive, by the env's rule) or ``failure`` (not
    success).

    Raises:
        ValueError: an unknown outcome, or a run that has not flown one of the layouts (its name and the first
            missing seed).
    """
    if outcome not in (*EPISODE_OUTCOMES, "failure"):
        raise ValueError(f"outcome must be one of {', '.join(EPISODE_OUTCOMES)}, failure; got {outcome!r}")
    flown = {}
    for row in rows:
        ended = episode_outcome(bool(row["collision"]), bool(row["out_of_bounds"]), bool(row["success"]))
        flown[(str(row["agent"]), layout_seed(row))] = (
            (ended != "success") if outcome == "failure" else ended == outcome
        )
    outcomes = np.zeros((len(runs), len(layouts)))
    for i, run in enumerate(runs):
        for j, seed in enumerate(layouts):
            if (run, seed) not in flown:
                raise ValueError(
                    f"run {run!r} has not flown layout {seed}: fly every run on the same layouts"
                )
            outcomes[i, j] = flown[(run, seed)]
    return outcomes


def block_scores(outcomes: np.ndarray, block: int = LAYOUT_BLOCK) -> np.ndarray:
    """Success rate of each run on each block of ``block`` consecutive layouts: (runs, blocks); a last
    incomplete block is dropped, so that every task weighs the same.

    Raises:
        ValueError: fewer layouts than one block.
    """
    runs, layouts = outcomes.shape
    blocks = layouts // block
    if blocks == 0:
        raise ValueError(f"need at least one block of {block} layouts, got {layouts}")
    return outcomes[:, : blocks * block].reshape(runs, blocks, block).mean(axis=2)


def _iqm(scores: np.ndarray) -> float:
    from rliable import metrics  # heavy, as above

    return float(metrics.aggregate_iqm(scores))


def interval_estimates(
    scores: Mapping[str, np.ndarray], seed: int = 0, reps: int = BOOTSTRAP_REPS
) -> dict[str, dict[str, float]]:
    """Mean and interquartile mean (IQM) of each agent's block scores with their stratified-bootstrap 95 %
    intervals over runs (rliable); an agent of one run gets a zero-width interval (nothing to resample)."""

    def aggregates(matrix: np.ndarray) -> np.ndarray:
        return np.array([float(np.mean(matrix)), _iqm(matrix)])

    points, intervals = _rliable_estimates(scores, aggregates, seed, reps)
    return {
        name: {
            "mean": float(points[name][0]),
            "mean_low": float(intervals[name][0, 0]),
            "mean_high": float(intervals[name][1, 0]),
            "iqm": float(points[name][1]),
            "iqm_low": float(intervals[name][0, 1]),
            "iqm_high": float(intervals[name][1, 1]),
        }
        for name in scores
    }


def probability_of_improvement(
    scores_x: np.ndarray, scores_y: np.ndarray, seed: int = 0, reps: int = IMPROVEMENT_REPS
) -> tuple[float, float, float]:
    """P(X > Y): the chance that a run of X beats a run of Y on a random block of layouts (ties count half),
    with its stratified-bootstrap 95 % interval (rliable's bootstrap, :func:`improvement_probability` in each
    replicate)."""
    points, intervals = _rliable_estimates(
        {"pair": (scores_x, scores_y)}, improvement_probability, seed, reps
    )
    low, high = np.ravel(intervals["pair"])
    return float(points["pair"]), float(low), float(high)


def improvement_probability(scores_x: np.ndarray, scores_y: np.ndarray) -> float:
    """rliable's ``metrics.probability_of_improvement`` without a Mann-Whitney test per task: per task (column),
    the share of (run of X, run of Y) pairs where X scores higher, ties counting half, which is the test's U
    statistic over n·m; averaged over tasks. The same number, about a hundred times faster, which matters
    because the bootstrap calls it thousands of times per pair of agents."""
    x = np.asarray(scores_x, np.float64)[:, None, :]
    y = np.asarray(scores_y, np.float64)[None, :, :]
    per_task = ((x > y) + 0.5 * (x == y)).mean(axis=(0, 1))
    return float(per_task.mean())
