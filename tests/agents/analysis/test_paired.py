"""Paired comparisons: the bootstrap pairs layouts and resamples runs, Holm corrects, the top group holds what
no corrected test separates from the best, and privileged or provisional agents are never ranked."""

from __future__ import annotations

import re

import numpy as np
import pytest

from agents.analysis.paired import (
    BOOTSTRAP_REPS,
    MIN_RANKED_SEEDS,
    SIGNIFICANCE,
    bootstrap_means,
    compare,
    holm,
    p_value_error,
    paired_bootstrap,
    probability_of_improvement,
    provisional_note,
    rank_tier,
    resample_counts,
    runs_interval,
    seed_interval,
    two_sided_p_value,
)
from agents.analysis.statistics import runs_and_layouts_interval


def _failures(rate: float, runs: int = 1, layouts: int = 300, seed: int = 0) -> np.ndarray:
    return (np.random.default_rng(seed).random((runs, layouts)) < rate).astype(float)


def test_pairing_by_layout_narrows_the_interval_of_agents_that_fail_on_the_same_layouts() -> None:
    hard_layouts = _failures(0.3, seed=1)
    one_more = hard_layouts.copy()
    one_more[0, np.flatnonzero(hard_layouts[0] == 0)[:15]] = 1.0  # fails where the other does, and 15 more
    draws = paired_bootstrap(one_more, hard_layouts, seed=0)
    assert np.all(draws >= 0.0)  # paired, the difference never changes sign
    comparison = compare("worse", one_more, "better", hard_layouts)
    assert comparison.difference == pytest.approx(15 / 300) and comparison.low > 0.0
    assert comparison.p_value < 0.01 and comparison.probability_of_improvement < 0.5


def test_identical_agents_are_not_separated() -> None:
    same = _failures(0.2)
    comparison = compare("a", same, "b", same)
    assert comparison.difference == 0.0 and comparison.p_value == 1.0
    assert comparison.probability_of_improvement == 0.5


def test_the_agent_that_fails_less_is_read_from_the_interval() -> None:
    hard_layouts = _failures(0.3, seed=1)
    one_more = hard_layouts.copy()
    one_more[0, np.flatnonzero(hard_layouts[0] == 0)[:15]] = 1.0
    assert compare("worse", one_more, "better", hard_layouts).fails_less == "better"
    assert compare("better", hard_layouts, "worse", one_more).fails_less == "better"
    assert compare("a", hard_layouts, "b", hard_layouts).fails_less is None  # the interval holds 0


def test_spread_between_training_runs_widens_the_paired_interval() -> None:
    reference = _failures(0.2, seed=3)
    steady = np.vstack([_failures(0.2, seed=10 + k) for k in range(10)])
    spread = np.vstack([_failures(rate, seed=10 + k) for k, rate in enumerate(np.linspace(0.0, 0.4, 10))])
    narrow, wide = compare("s", steady, "r", reference), compare("w", spread, "r", reference)
    assert (wide.high - wide.low) > (narrow.high - narrow.low)


def test_holm_multiplies_the_smallest_by_the_family_size_and_keeps_the_order() -> None:
    assert holm([0.01, 0.04, 0.03]) == pytest.approx([0.03, 0.06, 0.06])
    assert holm([0.5]) == [0.5]


def test_a_learned_agents_interval_is_never_narrower_than_the_t_interval_over_its_seeds() -> None:
    runs = np.vstack([_failures(rate, seed=k) for k, rate in enumerate([0.04, 0.08, 0.08, 0.38, 0.64])])
    low, high = seed_interval(runs)
    means = runs.mean(axis=1)
    assert low < means.mean() < high and high - low > 0.5  # the spread of five seeds, not of 1,500 episodes
    assert seed_interval(runs[:1]) == (means[0], means[0])


def test_runs_interval_is_the_wider_of_the_bootstrap_and_the_t_interval_within_0_and_1() -> None:
    spread = np.vstack([_failures(rate, seed=k) for k, rate in enumerate([0.04, 0.08, 0.08, 0.38, 0.64])])
    assert runs_interval(spread) == (max(0.0, seed_interval(spread)[0]), seed_interval(spread)[1])
    alike = np.vstack([_failures(0.2, seed=k) for k in range(5)])  # seeds alike: the layouts' noise rules
    boot_low, boot_high = runs_and_layouts_interval(alike)
    low, high = runs_interval(alike)
    assert (low, high) == (min(boot_low, seed_interval(alike)[0]), max(boot_high, seed_interval(alike)[1]))
    assert high - low >= boot_high - boot_low
    assert runs_interval(_failures(0.0, runs=3)) == (0.0, 0.0)


def test_runs_interval_refuses_what_is_not_a_runs_by_layouts_matrix() -> None:
    with pytest.raises(ValueError, match=r"outcomes must be a \(runs, layouts\) matrix .* got \(4,\)"):
        runs_interval(np.zeros(4))


def test_the_top_group_holds_what_no_corrected_test_separates_and_leaves_out_references() -> None:
    failures = {
        "best": _failures(0.10, seed=1),
        "close": _failures(0.11, seed=2),
        "far": _failures(0.60, seed=3),
        "oracle": _failures(0.0, runs=5, seed=4),
        "learned": _failures(0.0, runs=MIN_RANKED_SEEDS - 1, seed=5),
    }
    ranking = rank_tier(failures, privileged=["oracle"], learned=["oracle", "learned"])
    assert ranking.best == "best" and ranking.top_group == ("best", "close")
    assert ranking.left_out == {
        "oracle": "privileged: a reference",
        "learned": f"provisional ({MIN_RANKED_SEEDS - 1} seeds)",
    }
    assert {c.agent for c in ranking.comparisons} == {"close", "far"}
    far = next(c for c in ranking.comparisons if c.agent == "far")
    assert far.separated and far.p_holm >= far.p_value


def test_bad_input_is_one_line() -> None:
    with pytest.raises(
        ValueError, match=re.escape("paired agents must share their layouts: 300 against 200")
    ):
        paired_bootstrap(_failures(0.1), _failures(0.1, layouts=200))
    with pytest.raises(
        ValueError, match=re.escape("agent must be a (runs, layouts) matrix with at least 2 layouts")
    ):
        probability_of_improvement(np.zeros(3), np.zeros((1, 3)))
    with pytest.raises(ValueError, match="no agent to rank: every agent is privileged or provisional"):
        rank_tier({"oracle": _failures(0.0)}, privileged=["oracle"])


def test_a_comparison_names_the_learned_agents_it_rests_on_too_few_seeds_of() -> None:
    rng = np.random.default_rng(3)
    few = (rng.random((MIN_RANKED_SEEDS - 7, 40)) < 0.3).astype(float)
    enough = (rng.random((MIN_RANKED_SEEDS, 40)) < 0.3).astype(float)
    rule = (rng.random((1, 40)) < 0.3).astype(float)
    c = compare("ppo_oracle", few, "bee_ttc", rule)
    assert (c.agent_runs, c.reference_runs) == (MIN_RANKED_SEEDS - 7, 1)
    assert provisional_note(c) == f"; provisional: `ppo_oracle` ({MIN_RANKED_SEEDS - 7} training seeds)"
    assert provisional_note(compare("ppo_flow@all", enough, "bee_ttc", rule)) == ""
    both = provisional_note(compare("ppo_flow", enough[:1], "ppo_robust@all", few))
    assert (
        both
        == f"; provisional: `ppo_flow` (1 training seed) and `ppo_robust` ({MIN_RANKED_SEEDS - 7} training seeds)"
    )
    assert (
        provisional_note(compare("my_agent.py:make", rule, "bee", rule)) == ""
    )  # rules and outside agents: one run


def _index_bootstrap(agent: np.ndarray, reference: np.ndarray, reps: int, seed: int) -> np.ndarray:
    """The paired bootstrap by picking cells: layouts picked once for both, each agent's runs on their own."""
    rng = np.random.default_rng(seed)
    layouts = rng.integers(agent.shape[1], size=(reps, 1, agent.shape[1]))
    own = rng.integers(agent.shape[0], size=(reps, agent.shape[0], 1))
    theirs = rng.integers(reference.shape[0], size=(reps, reference.shape[0], 1))
    return agent[own, layouts].mean(axis=(1, 2)) - reference[theirs, layouts].mean(axis=(1, 2))


@pytest.mark.parametrize("agent_runs", [1, 10])
def test_counted_draws_follow_the_bootstrap_that_picks_cells(agent_runs: int) -> None:
    rates = np.linspace(0.1, 0.5, agent_runs)[:, None]
    agent = (np.random.default_rng(1).random((agent_runs, 300)) < rates).astype(float)
    reference = _failures(0.25, runs=10, seed=2)
    reference[:, :100] = np.maximum(
        reference[:, :100], agent[:1, :100]
    )  # shared hard layouts: pairing matters
    reps = 20_000
    counted = paired_bootstrap(agent, reference, reps=reps, seed=3)
    picked = _index_bootstrap(agent, reference, reps, seed=4)
    spread = picked.std()
    assert counted.mean() == pytest.approx(picked.mean(), abs=5 * spread / np.sqrt(reps))
    assert counted.std() == pytest.approx(spread, rel=0.03)
    # the 95 % interval's ends, each within a few Monte Carlo errors of a percentile of 20,000 draws
    assert np.percentile(counted, [2.5, 97.5]) == pytest.approx(
        np.percentile(picked, [2.5, 97.5]), abs=0.1 * spread
    )


def test_resampled_counts_are_multinomial_draws_of_every_item() -> None:
    counts = resample_counts(np.random.default_rng(0), 7, 5_000)
    assert counts.shape == (5_000, 7) and np.all(counts.sum(axis=1) == 7)
    assert counts.mean(axis=0) == pytest.approx(
        np.ones(7), abs=0.05
    )  # each item picked once per draw on average
    assert counts.var(axis=0) == pytest.approx(np.full(7, 6 / 7), rel=0.1)  # binomial(7, 1/7)


def test_a_p_value_near_the_cut_is_known_to_a_few_thousandths() -> None:
    assert p_value_error(SIGNIFICANCE, BOOTSTRAP_REPS) < 0.0015
    # Holm's multiplier for the most comparisons a suite tier holds (its agents but the best) stays well inside
    assert p_value_error(SIGNIFICANCE, BOOTSTRAP_REPS, multiplier=10) < 0.0035
    assert p_value_error(0.05, 100) == pytest.approx(2 * np.sqrt(0.025 * 0.975 / 100))
    assert p_value_error(0.05, 100, multiplier=4) == pytest.approx(4 * 2 * np.sqrt(0.00625 * 0.99375 / 100))


def test_a_p_value_moves_between_bootstrap_seeds_by_its_stated_error() -> None:
    rng = np.random.default_rng(7)
    reference = (rng.random((1, 300)) < 0.2).astype(float)
    agent = reference.copy()
    agent[0, np.flatnonzero(reference[0] == 0)[:8]] = 1.0  # 8 more failures: p near 0.01
    reps = 20_000
    p_values = [two_sided_p_value(paired_bootstrap(agent, reference, reps=reps, seed=s)) for s in range(12)]
    error = p_value_error(float(np.mean(p_values)), reps)
    assert np.std(p_values, ddof=1) == pytest.approx(error, rel=0.6)


def test_the_top_group_is_the_same_under_other_bootstrap_seeds() -> None:
    failures = {
        "best": _failures(0.10, seed=1),
        "close": _failures(0.11, seed=2),
        "learned": _failures(0.13, runs=MIN_RANKED_SEEDS, seed=5),
        "far": _failures(0.60, seed=3),
    }
    groups = {rank_tier(failures, learned=["learned"], seed=seed).top_group for seed in range(3)}
    assert groups == {("best", "close", "learned")}


def test_bootstrap_means_pair_every_matrix_on_the_same_layout_draws() -> None:
    same = _failures(0.3)
    means = bootstrap_means({"a": same, "b": same.copy(), "c": _failures(0.3, runs=3)}, reps=500)
    assert np.array_equal(means["a"], means["b"])  # one run each, the same layouts drawn: exactly equal means
    assert two_sided_p_value(means["a"] - means["b"]) == 1.0


def test_bad_bootstrap_input_is_one_line() -> None:
    with pytest.raises(ValueError, match=re.escape("no (runs, layouts) matrix to draw from")):
        bootstrap_means({})
    with pytest.raises(ValueError, match=re.escape("paired agents must share their layouts: 300 against 50")):
        bootstrap_means({"a": _failures(0.1), "b": _failures(0.1), "c": _failures(0.1, layouts=50)})
    with pytest.raises(ValueError, match=re.escape("c must be a (runs, layouts) matrix")):
        bootstrap_means({"c": np.zeros(3)})
    with pytest.raises(ValueError, match=re.escape("p_value must lie in (0, 1], got 0.0")):
        p_value_error(0.0)
    with pytest.raises(ValueError, match=re.escape("reps and multiplier must be at least 1, got 0 and 1")):
        p_value_error(0.05, 0)
    with pytest.raises(ValueError, match=re.escape("reps and multiplier must be at least 1, got 10 and 0")):
        p_value_error(0.05, 10, multiplier=0)
