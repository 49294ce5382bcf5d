"""Paired comparisons of agents flown on the same layouts: the one place the benchmark decides that one agent
fails less than another.

An agent's outcomes are a (runs, layouts) matrix of failures (1) and successes (0): one run for a rule, one per
training seed for a learned agent. Two agents are compared on the layouts both flew, by a bootstrap that draws
the layouts once for both (the pairing) and each agent's training runs separately (so a learned agent's spread
between seeds widens the interval, as rliable's stratified bootstrap does). Beside the interval: the
probability of improvement (Agarwal et al. 2021) and a two-sided bootstrap p-value, Holm-corrected across a
tier's comparisons. The agents no corrected test separates from a tier's best form its top group.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy import stats

from agents.analysis.statistics import runs_and_layouts_interval
from agents.common.agent_table import base_agent_name, kind_of

CONFIDENCE = 0.95
# Draws of every paired bootstrap: enough that a p-value near SIGNIFICANCE moves by about a thousandth from one
# bootstrap seed to another, a Holm-corrected one by a few (p_value_error), so a top group does not hang on the seed.
BOOTSTRAP_REPS = 100_000
# Draws are made in blocks of about this many resampled layouts, so that a block's counts stay a few megabytes.
DRAWN_CELLS = 1_000_000
# A corrected p-value at or above this leaves two agents unseparated.
SIGNIFICANCE = 0.05
# A learned agent needs this many training seeds for its rank to describe its recipe rather than its runs.
MIN_RANKED_SEEDS = 10


@dataclass(frozen=True)
class Comparison:
    """``agent`` against ``reference`` on shared layouts: failure difference (agent − reference) with its
    interval, the probability that ``agent`` does better, and the raw and Holm-corrected p-values."""

    agent: str
    reference: str
    difference: float
    low: float
    high: float
    probability_of_improvement: float
    p_value: float
    p_holm: float = 1.0
    # How many runs each side pooled: a learned agent's training seeds, 1 for a rule.
    agent_runs: int = 1
    reference_runs: int = 1

    @property
    def separated(self) -> bool:
        """Whether the corrected test tells the two apart."""
        return self.p_holm < SIGNIFICANCE

    @property
    def fails_less(self) -> str | None:
        """The agent that fails less by the 95 % interval of the difference (``agent`` where it lies below 0,
        ``reference`` where above), None where the interval holds 0: no difference shown."""
        if self.high < 0.0:
            return self.agent
        if self.low > 0.0:
            return self.reference
        return None


def _check(matrix: np.ndarray, name: str) -> np.ndarray:
    matrix = np.asarray(matrix, float)
    if matrix.ndim != 2 or matrix.shape[0] < 1 or matrix.shape[1] < 2:
        raise ValueError(
            f"{name} must be a (runs, layouts) matrix with at least 2 layouts, got {matrix.shape}"
        )
    return matrix


def resample_counts(rng: np.random.Generator, items: int, reps: int) -> np.ndarray:
    """How often each of ``items`` things is picked in each of ``reps`` draws of ``items`` with replacement: a
    (reps, items) array of counts, each row a multinomial draw summing to ``items``."""
    picked = rng.integers(items, size=(reps, items))
    picked += np.arange(0, reps * items, items)[:, None]  # each draw's picks offset to its own row of counts
    return np.bincount(picked.ravel(), minlength=reps * items).reshape(reps, items)


def bootstrap_means(
    matrices: Mapping[str, np.ndarray], reps: int = BOOTSTRAP_REPS, seed: int = 0
) -> dict[str, np.ndarray]:
    """``reps`` bootstrap draws of the mean of each named (runs, layouts) matrix: each draw resamples the layouts
    once for all the matrices (the pairing) and each matrix's runs on its own.

    Drawing L layouts and R runs with replacement and averaging the picked (run, layout) cells is the same as
    weighting the matrix by how often each run (counts c) and each layout (counts w) was picked: the draw's mean
    is c·A·w / (R·L). Counts and a matrix product stand in for the (reps, R, L) picked cells, so many draws cost
    little. Sums of 0/1 cells stay whole numbers, so a draw of no difference between two agents is exactly 0.

    Raises:
        ValueError: no matrix, or not (runs, layouts) matrices on the same number of layouts.
    """
    checked = {name: _check(matrix, name) for name, matrix in matrices.items()}
    if not checked:
        raise ValueError("no (runs, layouts) matrix to draw from")
    layouts = next(iter(checked.values())).shape[1]
    for matrix in checked.values():
        if matrix.shape[1] != layouts:
            raise ValueError(f"paired agents must share their layouts: {layouts} against {matrix.shape[1]}")
    rng = np.random.default_rng(seed)
    means = {name: np.empty(reps) for name in checked}
    block = max(1, DRAWN_CELLS // layouts)
    for start in range(0, reps, block):
        count = min(block, reps - start)
        layout_counts = resample_counts(rng, layouts, count).astype(float)
        for name, matrix in checked.items():
            run_counts = resample_counts(rng, matrix.shape[0], count)
            # einsum's own loops, not a threaded BLAS product: the flights keep every core busy.
            per_run = np.einsum("dl,rl->dr", layout_counts, matrix)
            means[name][start : start + count] = np.einsum("dr,dr->d", run_counts, per_run) / matrix.size
    return means


def paired_bootstrap(
    agent: np.ndarray, reference: np.ndarray, reps: int = BOOTSTRAP_REPS, seed: int = 0
) -> np.ndarray:
    """``reps`` bootstrap draws of mean failure(agent) − mean failure(reference): layouts drawn once for both,
    each agent's runs drawn on their own (:func:`bootstrap_means`).

    Raises:
        ValueError: not (runs, layouts) matrices on the same number of layouts.
    """
    means = bootstrap_means({"agent": agent, "reference": reference}, reps, seed)
    return means["agent"] - means["reference"]


def probability_of_improvement(agent: np.ndarray, reference: np.ndarray) -> float:
    """P(a run of ``agent`` fails less than a run of ``reference`` on a layout), ties counted half, averaged over
    layouts: rliable's probability of improvement for binary failures (0.5: no difference)."""
    agent, reference = _check(agent, "agent"), _check(reference, "reference")
    better = (agent[:, None, :] < reference[None, :, :]).mean(axis=(0, 1))
    ties = (agent[:, None, :] == reference[None, :, :]).mean(axis=(0, 1))
    return float(np.mean(better + 0.5 * ties))


def compare(
    name: str, agent: np.ndarray, reference_name: str, reference: np.ndarray, seed: int = 0
) -> Comparison:
    """``agent`` against ``reference`` (:class:`Comparison`, ``p_holm`` still the raw p-value).

    Raises:
        ValueError: not (runs, layouts) matrices on the same number of layouts.
    """
    draws = paired_bootstrap(agent, reference, seed=seed)
    return _comparison(name, np.asarray(agent, float), reference_name, np.asarray(reference, float), draws)


def _comparison(
    name: str, agent: np.ndarray, reference_name: str, reference: np.ndarray, draws: np.ndarray
) -> Comparison:
    """:class:`Comparison` of ``agent`` with ``reference`` from bootstrap ``draws`` of their difference."""
    tail = (1.0 - CONFIDENCE) / 2.0 * 100.0
    low, high = np.percentile(draws, [tail, 100.0 - tail])
    p = float(max(two_sided_p_value(draws), 1.0 / len(draws)))  # never below what the draws can resolve
    difference = float(np.mean(agent) - np.mean(reference))
    return Comparison(
        name,
        reference_name,
        difference,
        float(low),
        float(high),
        probability_of_improvement(agent, reference),
        p,
        p,
        agent_runs=agent.shape[0],
        reference_runs=reference.shape[0],
    )


def two_sided_p_value(draws: np.ndarray) -> float:
    """Two-sided bootstrap p-value of a difference: twice the share of ``draws`` on the rarer side of zero
    (draws at zero count on both sides), at most 1."""
    return min(1.0, 2.0 * min(float(np.mean(draws <= 0.0)), float(np.mean(draws >= 0.0))))


def p_value_error(p_value: float = SIGNIFICANCE, reps: int = BOOTSTRAP_REPS, multiplier: int = 1) -> float:
    """Monte Carlo standard error of a bootstrap p-value near ``p_value`` from ``reps`` draws: the p-value is
    twice a share of draws, q = p / 2, so its error is 2·√(q(1 − q) / reps). A Holm-corrected p-value that
    multiplied its raw p-value by ``multiplier`` k reaches ``p_value`` from a raw one of p / k, and its error is
    k times that one's: about √k times the uncorrected error.

    Raises:
        ValueError: a p-value outside (0, 1], fewer than 1 draw, or a multiplier below 1.
    """
    if not 0.0 < p_value <= 1.0:
        raise ValueError(f"p_value must lie in (0, 1], got {p_value}")
    if reps < 1 or multiplier < 1:
        raise ValueError(f"reps and multiplier must be at least 1, got {reps} and {multiplier}")
    share = p_value / multiplier / 2.0
    return float(multiplier * 2.0 * np.sqrt(share * (1.0 - share) / reps))


def verdict(comparison: Comparison, agent: str = "", reference: str = "") -> str:
    """ "X fails less than Y", "Y fails less than X" or "no difference shown", worded from where the interval of
    the difference lies (:attr:`Comparison.fails_less`); the two named by ``agent`` and ``reference``, else by
    their names in backticks."""
    agent = agent or f"`{comparison.agent}`"
    reference = reference or f"`{comparison.reference}`"
    if comparison.fails_less == comparison.agent:
        return f"{agent} fails less than {reference}"
    if comparison.fails_less == comparison.reference:
        return f"{reference} fails less than {agent}"
    return "no difference shown"


def provisional_note(comparison: Comparison) -> str:
    """What a sentence worded from ``comparison`` adds when a learned agent in it pooled fewer than
    :data:`MIN_RANKED_SEEDS` training seeds (``"; provisional: `ppo_oracle` (5 training seeds)"``), so that no
    comparison resting on a few runs reads like one about a recipe; empty otherwise."""
    sides = ((comparison.agent, comparison.agent_runs), (comparison.reference, comparison.reference_runs))
    few = [
        f"`{base_agent_name(name)}` ({runs} training seed{'s' if runs != 1 else ''})"
        for name, runs in sides
        if kind_of(name) == "learned" and runs < MIN_RANKED_SEEDS
    ]
    return f"; provisional: {' and '.join(few)}" if few else ""


def holm(p_values: Sequence[float]) -> list[float]:
    """Holm's step-down correction of ``p_values`` (family-wise error), in their order."""
    order = np.argsort(p_values, kind="stable")
    adjusted = np.empty(len(p_values))
    running = 0.0
    for rank, index in enumerate(order):
        running = max(running, min(1.0, (len(p_values) - rank) * p_values[index]))
        adjusted[index] = running
    return adjusted.tolist()


def seed_interval(runs: np.ndarray) -> tuple[float, float]:
    """95 % t-interval of the mean failure over the runs' own means: the narrowest a learned agent's interval
    may be, since its claim is about its recipe, of which its runs are a sample. ``(mean, mean)`` for one run.

    Raises:
        ValueError: not a (runs, layouts) matrix.
    """
    means = _check(runs, "runs").mean(axis=1)
    if len(means) < 2:
        return float(means[0]), float(means[0])
    half = stats.t.ppf(0.5 + CONFIDENCE / 2.0, len(means) - 1) * means.std(ddof=1) / np.sqrt(len(means))
    return float(means.mean() - half), float(means.mean() + half)


RUNS_INTERVAL = "runs × layouts (bootstrap, at least the t-interval over runs)"
"""How :func:`runs_interval` is made, as a table's "interval over" column names it."""


def runs_interval(outcomes: np.ndarray) -> tuple[float, float]:
    """95 % interval of a learned agent's rate over its runs and layouts (``outcomes``: (runs, layouts) of 0/1,
    every run on the same layouts): the wider of the two-level bootstrap (runs, then layouts:
    :func:`agents.analysis.statistics.runs_and_layouts_interval`) and the t-interval over the runs' own rates
    (:func:`seed_interval`), clipped to [0, 1]. With few runs the bootstrap understates the spread between
    training runs; the t-interval is the floor that keeps the interval about the recipe, not its runs.

    Raises:
        ValueError: not a (runs, layouts) matrix.
    """
    matrix = _check(outcomes, "outcomes")
    low, high = runs_and_layouts_interval(matrix)
    t_low, t_high = seed_interval(matrix)
    return max(0.0, min(low, t_low)), min(1.0, max(high, t_high))


@dataclass(frozen=True)
class TierRanking:
    """A tier's ranking: its best rankable agent, each other rankable agent against it, the top group (the best
    and those no corrected test separates from it), and the agents left out with why."""

    best: str
    comparisons: tuple[Comparison, ...]
    top_group: tuple[str, ...]
    left_out: Mapping[str, str]


def _left_out(
    failures: Mapping[str, np.ndarray], privileged: Sequence[str], learned: Sequence[str]
) -> dict[str, str]:
    """The agents not ranked, with why: privileged ones, and learned ones with too few training seeds."""
    left_out = {name: "privileged: a reference" for name in failures if name in privileged}
    for name in failures:
        runs = np.asarray(failures[name]).shape[0]
        if name not in left_out and name in learned and runs < MIN_RANKED_SEEDS:
            left_out[name] = f"provisional ({runs} seeds)"
    return left_out


def rank_tier(
    failures: Mapping[str, np.ndarray],
    *,
    privileged: Sequence[str] = (),
    learned: Sequence[str] = (),
    seed: int = 0,
) -> TierRanking:
    """Rank the agents of one tier from their failure matrices (runs, layouts), on the same layouts, by the
    paired bootstrap drawn from ``seed``.

    A privileged agent (it reads what the tier's sensor does not give) is a reference and never ranked; a
    learned agent with fewer than :data:`MIN_RANKED_SEEDS` runs is provisional and not ranked either.

    Raises:
        ValueError: no rankable agent, or matrices on different numbers of layouts.
    """
    left_out = _left_out(failures, privileged, learned)
    rankable = {name: np.asarray(matrix, float) for name, matrix in failures.items() if name not in left_out}
    if not rankable:
        raise ValueError(
            f"no agent to rank: every agent is privileged or provisional ({', '.join(failures)})"
        )
    best = min(rankable, key=lambda name: (float(np.mean(rankable[name])), name))
    # One draw of the layouts for the whole tier: each comparison's draws are paired_bootstrap's, made once.
    means = bootstrap_means(rankable, seed=seed) if len(rankable) > 1 else {}
    raw = [
        _comparison(name, matrix, best, rankable[best], means[name] - means[best])
        for name, matrix in rankable.items()
        if name != best
    ]
    corrected = holm([c.p_value for c in raw])
    comparisons = tuple(
        Comparison(**{**c.__dict__, "p_holm": p}) for c, p in zip(raw, corrected, strict=True)
    )
    top = (best, *(c.agent for c in sorted(comparisons, key=lambda c: c.difference) if not c.separated))
    return TierRanking(best, comparisons, top, left_out)
