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
BOOTSTRAP_REPS = 2_000
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


def paired_bootstrap(
    agent: np.ndarray, reference: np.ndarray, reps: int = BOOTSTRAP_REPS, seed: int = 0
) -> np.ndarray:
    """``reps`` bootstrap draws of mean failure(agent) − mean failure(reference): layouts drawn once for both,
    each agent's runs drawn on their own.

    Raises:
        ValueError: not (runs, layouts) matrices on the same number of layouts.
    """
    agent, reference = _check(agent, "agent"), _check(reference, "reference")
    if agent.shape[1] != reference.shape[1]:
        raise ValueError(
            f"paired agents must share their layouts: {agent.shape[1]} against {reference.shape[1]}"
        )
    rng = np.random.default_rng(seed)
    layouts = agent.shape[1]
    draws = np.empty(reps)
    for start in range(0, reps, 250):  # blocks keep the index arrays small for 10 runs × 300 layouts
        count = min(250, reps - start)
        chosen = rng.integers(layouts, size=(count, 1, layouts))
        own = rng.integers(agent.shape[0], size=(count, agent.shape[0], 1))
        theirs = rng.integers(reference.shape[0], size=(count, reference.shape[0], 1))
        draws[start : start + count] = agent[own, chosen].mean(axis=(1, 2)) - reference[theirs, chosen].mean(
            axis=(1, 2)
        )
    return draws


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
    """``agent`` against ``reference`` (:class:`Comparison`, ``p_holm`` still the raw p-value)."""
    draws = paired_bootstrap(agent, reference, seed=seed)
    tail = (1.0 - CONFIDENCE) / 2.0 * 100.0
    low, high = np.percentile(draws, [tail, 100.0 - tail])
    # Two-sided: how often the resampled difference lands on either side of zero; never below 1 / reps.
    p = min(1.0, 2.0 * min(float(np.mean(draws <= 0.0)), float(np.mean(draws >= 0.0))))
    p = float(max(p, 1.0 / len(draws)))
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
    failures: Mapping[str, np.ndarray], *, privileged: Sequence[str] = (), learned: Sequence[str] = ()
) -> TierRanking:
    """Rank the agents of one tier from their failure matrices (runs, layouts), on the same layouts.

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
    raw = [compare(name, matrix, best, rankable[best]) for name, matrix in rankable.items() if name != best]
    corrected = holm([c.p_value for c in raw])
    comparisons = tuple(
        Comparison(**{**c.__dict__, "p_holm": p}) for c, p in zip(raw, corrected, strict=True)
    )
    top = (best, *(c.agent for c in sorted(comparisons, key=lambda c: c.difference) if not c.separated))
    return TierRanking(best, comparisons, top, left_out)
