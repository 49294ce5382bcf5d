"""corridor_exists: a geometric reachability sweep, apart from the planner, that says whether a layout has a way
through at all."""

from __future__ import annotations

import re

import numpy as np
import pytest

from agents.policies.planner_feasibility import corridor_exists

HARD = {
    "goal_x": 20.0,
    "forward_speed": 2.0,
    "max_lateral_speed": 1.0,
    "lateral_bound": 6.0,
    "drone_radius": 0.2,
}


def wall(x: float, ys: np.ndarray, radius: float = 0.5) -> np.ndarray:
    return np.column_stack([np.full(len(ys), x), ys, np.full(len(ys), radius)])


def test_an_empty_field_and_padding_rows_are_open() -> None:
    assert corridor_exists(np.zeros((0, 3)), **HARD)
    assert corridor_exists(np.zeros((64, 3)), **HARD)


def test_a_wall_across_the_whole_width_is_closed() -> None:
    assert not corridor_exists(wall(10.0, np.arange(-6.5, 7.0, 0.9)), **HARD)


def wall_with_gap(centre: float) -> np.ndarray:
    """Touching capsules across the whole width but one gap of 1.0 m between surfaces, centred at ``centre``."""
    steps = np.arange(0.0, 14.0)
    ys = np.concatenate([centre - 1.0 - steps, centre + 1.0 + steps])
    return wall(10.0, ys[np.abs(ys) < 7.0])


def test_a_gap_counts_only_if_the_hull_fits_and_the_slope_reaches_it() -> None:
    # The 0.4 m hull fits a 1.0 m gap; a 1.1 m one does not.
    assert corridor_exists(wall_with_gap(0.0), **HARD)
    assert not corridor_exists(wall_with_gap(0.0), **{**HARD, "drone_radius": 0.55})
    # A gap 4 m to the side is within reach at slope 0.5 from 10 m out, not at slope 0.2.
    assert corridor_exists(wall_with_gap(4.0), **HARD)
    assert not corridor_exists(wall_with_gap(4.0), **{**HARD, "max_lateral_speed": 0.4})


@pytest.mark.parametrize(
    ("name", "message"),
    [
        ("forward_speed", "forward_speed must be > 0, got 0.0"),
        ("lateral_step", "lateral_step must be > 0, got 0.0"),
    ],
)
def test_a_bad_argument_is_one_line(name: str, message: str) -> None:
    with pytest.raises(ValueError, match=re.escape(message)):
        corridor_exists(np.zeros((0, 3)), **{**HARD, name: 0.0})


def test_a_layout_of_the_wrong_shape_is_one_line() -> None:
    with pytest.raises(
        ValueError, match=re.escape("layout must have shape (N, 3) of x, y, radius, got (4, 2)")
    ):
        corridor_exists(np.zeros((4, 2)), **HARD)
