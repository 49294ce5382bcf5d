"""verify's sample is sized by a stated detection power, and episodes re-flown on another CPU are judged by an
exact one-sided McNemar test."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from agents.analysis.detection import detection_power, detection_sample_size, discordance_p_value


@pytest.mark.parametrize("total", [40, 300, 1200])
def test_the_default_sample_catches_two_percent_changed_with_95_percent(total: int) -> None:
    size = detection_sample_size(total)
    changed = math.ceil(0.02 * total)
    assert detection_power(total, changed, size) >= 0.95
    assert detection_power(total, changed, size - 1) < 0.95  # and no larger than that takes


def test_the_old_sample_of_ten_per_tier_caught_three_flipped_episodes_one_time_in_ten() -> None:
    assert detection_power(300, 3, 10) == pytest.approx(0.097, abs=5e-4)


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        ((0,), "the episodes to draw from must be a whole number >= 1, got 0"),
        ((10, 0.0), "--detect must be a share of the episodes in (0, 1], got 0.0"),
        ((10, 0.02, 1.0), "--power must be a probability in (0, 1), got 1.0"),
    ],
)
def test_bad_sizes_are_one_line(arguments: tuple, message: str) -> None:
    with pytest.raises(ValueError, match=f"^{message.replace('(', '[(]').replace(')', '[)]')}$"):
        detection_sample_size(*arguments)


def test_discordance_one_way_is_caught_and_both_ways_is_not() -> None:
    assert discordance_p_value(6, 0) == pytest.approx(1 / 64)
    assert discordance_p_value(3, 3) > 0.5
    assert discordance_p_value(0, 0) == 1.0


def test_the_readmes_sample_for_a_full_score_is_what_the_code_draws() -> None:
    readme = (Path(__file__).resolve().parents[3] / "README.md").read_text()
    assert f"{detection_sample_size(1200)} of 1,200 episodes" in readme
