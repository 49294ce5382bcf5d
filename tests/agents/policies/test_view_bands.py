"""Regions of the view read off any column count: the rules' laws at 5 columns bit for bit as when written in
columns, the same angles at 15."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from agents.policies import load_agent
from agents.policies.reactive import BeeAgent, heights_and_headings
from agents.policies.view_bands import (
    band_columns,
    band_mean,
    column_weights,
    smooth_across_columns,
    triangle_kernel,
)


def _random_observations(cols: int, bins: int = 6, batch: int = 64, seed: int = 0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    histogram = rng.random((batch, 3, cols, bins)) ** 3
    histogram /= histogram.sum(axis=-1, keepdims=True)
    histogram[rng.random((batch, 3, cols)) < 0.1] = 0.0  # some empty sectors
    state = rng.normal(size=(batch, 7))
    state[:, 0] = rng.uniform(0.5, 2.5, batch)  # forward speed
    return {
        "depth_histogram": histogram.astype(np.float32),
        "unresolved": rng.uniform(0, 0.5, (batch, 3, cols)).astype(np.float32),
        "state": state.astype(np.float32),
    }


def _bee_law_in_columns(
    agent: BeeAgent, nearness: np.ndarray, observation: dict[str, np.ndarray]
) -> np.ndarray:
    """The bee's law as it was written in columns before it was written in shares of the view (odd counts)."""
    heights, headings, _ = heights_and_headings(observation)
    per_column = nearness.max(axis=1)
    cols = per_column.shape[1]
    half = cols // 2
    left = per_column[:, :half].mean(axis=1)
    right = per_column[:, cols - half :].mean(axis=1)
    centre = per_column[:, half : cols - half].max(axis=1)
    side = np.where(left >= right, 1.0, -1.0)
    looming = np.maximum(centre - agent.frontal_threshold, 0.0)
    lateral = agent.centring_gain * (left - right) + agent.frontal_gain * looming * side
    actions = np.zeros((len(heights), 3), np.float32)
    actions[:, 0] = np.clip(lateral, -1, 1)
    actions[:, 1] = np.clip(agent.height_gain * (agent.flight_height - heights), -1, 1)
    actions[:, 2] = np.clip(agent.heading_gain * headings + agent.yaw_gain * looming * side, -1, 1)
    return actions


@pytest.mark.parametrize("name", ["bee", "bee_robust", "bee_ttc"])
def test_the_bee_laws_at_five_columns_are_bit_for_bit_those_written_in_columns(name: str) -> None:
    agent = load_agent(name)
    observations = _random_observations(5)
    nearness = np.random.default_rng(1).uniform(0, 2, (64, 2, 5))
    expected = _bee_law_in_columns(agent, nearness, observations)
    assert np.array_equal(agent.centring_actions(nearness, observations), expected)
    actions, _ = agent.predict(observations)
    assert np.all(np.isfinite(actions))


def test_vfh_smoothing_at_five_columns_is_bit_for_bit_the_quarter_half_quarter_kernel() -> None:
    density = np.random.default_rng(2).random((64, 5))
    padded = np.pad(density, ((0, 0), (1, 1)), mode="edge")
    written_in_columns = 0.25 * padded[:, :-2] + 0.5 * padded[:, 1:-1] + 0.25 * padded[:, 2:]
    kernel = triangle_kernel(5, Fraction(2, 5))
    assert kernel.tolist() == [0.25, 0.5, 0.25]
    assert np.array_equal(smooth_across_columns(density, kernel), written_in_columns)


@pytest.mark.parametrize("name", ["bee", "bee_robust", "bee_ttc"])
def test_the_bee_laws_read_the_same_angles_at_fifteen_columns(name: str) -> None:
    # A scene at 15 columns that is the 5-column one with each column seen three times: the same actions.
    coarse = _random_observations(5)
    fine = {
        "depth_histogram": np.repeat(coarse["depth_histogram"], 3, axis=2),
        "unresolved": np.repeat(coarse["unresolved"], 3, axis=2),
        "state": coarse["state"],
    }
    agent = load_agent(name)
    np.testing.assert_allclose(agent.predict(fine)[0], agent.predict(coarse)[0], atol=1e-6)


def test_vfh_smooths_over_the_same_angles_at_any_column_count() -> None:
    for cols in (5, 9, 10, 15):
        kernel = triangle_kernel(cols, Fraction(2, 5))
        offsets = np.arange(len(kernel)) - len(kernel) // 2
        assert kernel.sum() == pytest.approx(1.0) and np.all(kernel > 0)
        # Its spread in shares of the view is, to a column's rounding, that of the triangle 2/5 of the view wide
        # either side (standard deviation 0.4 / sqrt(6)), at every count.
        spread = np.sqrt((kernel * (offsets / cols) ** 2).sum())
        assert spread == pytest.approx(0.4 / np.sqrt(6.0), rel=0.15)
    agent = load_agent("vfh")
    for cols in (5, 15):
        observation = _random_observations(cols, batch=1)
        observation["depth_histogram"][:] = 0.0
        observation["depth_histogram"][0, :2, :, 5] = 1.0  # far everywhere...
        near = slice(0, cols * 3 // 5)
        observation["depth_histogram"][0, :2, near] = 0.0
        observation["depth_histogram"][0, :2, near, 0] = 1.0  # ...but near on the left three fifths
        observation["unresolved"][:] = 0.0
        observation["state"][0, 6] = 0.0
        assert agent.predict(observation)[0][0, 0] > 0.3  # slides right at either count


def test_column_weights_cut_columns_at_the_bands_edges() -> None:
    assert column_weights(5, Fraction(0), Fraction(2, 5)).tolist() == [1.0, 1.0, 0.0, 0.0, 0.0]
    assert column_weights(9, Fraction(0), Fraction(2, 5)).tolist() == pytest.approx(
        [1, 1, 1, 0.6, 0, 0, 0, 0, 0]
    )
    assert band_mean(np.array([[1.0, 2.0, 4.0]]), Fraction(0), Fraction(1, 2)).tolist() == pytest.approx(
        [(1.0 + 0.5 * 2.0) / 1.5]
    )
    assert band_columns(5, Fraction(2, 5), Fraction(3, 5)).tolist() == [2]
    assert band_columns(15, Fraction(2, 5), Fraction(3, 5)).tolist() == [6, 7, 8]
    assert band_columns(4, Fraction(2, 5), Fraction(3, 5)).tolist() == [1, 2]  # no centre inside: the nearest


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: column_weights(0, Fraction(0), Fraction(1)), "columns must be an integer >= 1, got 0"),
        (
            lambda: band_columns(5, Fraction(1, 2), Fraction(1, 4)),
            r"0 <= start < stop <= 1, got \[1/2, 1/4\)",
        ),
        (lambda: column_weights(5, Fraction(0), Fraction(3, 2)), r"0 <= start < stop <= 1, got \[0, 3/2\)"),
        (lambda: triangle_kernel(5, Fraction(0)), r"half-width must be in \(0, 1\] of the view, got 0"),
        (lambda: triangle_kernel(True, Fraction(1, 5)), "columns must be an integer >= 1, got True"),
    ],
)
def test_bad_bands_are_refused_naming_the_value_and_the_range(call, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        call()


@pytest.mark.parametrize("name", ["bee", "bee_robust", "bee_ttc", "vfh"])
def test_a_rule_refuses_a_histogram_binned_otherwise_than_its_bin_edges(name: str) -> None:
    observation = _random_observations(5, bins=9, batch=1)
    with pytest.raises(
        ValueError, match=r"the depth histogram has 9 bins but the rule's bin_edges .* make 6: give"
    ):
        load_agent(name).predict(observation)
    fine = (0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 5.0, 8.0, 13.0)
    assert load_agent(name, bin_edges=fine).predict(observation)[0].shape == (1, 3)
