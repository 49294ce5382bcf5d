"""Rates per cell: failures count every episode that did not reach the goal, whatever ended it."""

from __future__ import annotations

import pytest

from agents.analysis.statistics import format_summary, summarise, wilson_interval


def _row(seed: int, *, collision: bool = False, success: bool = False, out_of_bounds: bool = False) -> dict:
    return {
        "agent": "bee",
        "factor": "clean",
        "level": 0.0,
        "seed": seed,
        "collision": collision,
        "success": success,
        "out_of_bounds": out_of_bounds,
        "progress_m": 5.0,
        "min_clearance_m": 0.3,
    }


def test_failures_are_collisions_out_of_bounds_and_timeouts() -> None:
    rows = [
        _row(0, success=True),
        _row(1, collision=True),
        _row(2, out_of_bounds=True),
        _row(3),  # the time limit: no goal, no collision
    ]
    (cell,) = summarise(rows)
    assert cell["failure_rate"] == pytest.approx(0.75) and cell["collision_rate"] == pytest.approx(0.25)
    assert cell["out_of_bounds"] == 1 and cell["success_rate"] == pytest.approx(0.25)
    assert (cell["failure_ci_low"], cell["failure_ci_high"]) == pytest.approx(wilson_interval(3, 4))
    table = format_summary([cell])
    assert "failure rate [95 % CI]" in table.splitlines()[0]
    assert "| 0.75 [" in table.splitlines()[2]


def test_fewer_collisions_with_more_failures_shows_in_the_failure_rate() -> None:
    # Leaving the course sideways avoids obstacles: collisions fall while failures rise.
    before = summarise([_row(s, collision=s < 2, success=s >= 2) for s in range(4)])[0]
    after = summarise([_row(s, collision=s < 1, out_of_bounds=s >= 1) for s in range(4)])[0]
    assert after["collision_rate"] < before["collision_rate"]
    assert after["failure_rate"] > before["failure_rate"]
