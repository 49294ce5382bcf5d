"""Is a course flyable at all? A geometric check apart from the planner's code, to tell a planner failure on a
layout with no way through ("infeasible") from one where a way existed ("planner miss").

The drone is a point that moves forward at ``forward_speed`` and sideways at most ``max_lateral_speed``, so its
path y(x) has slope at most ``max_lateral_speed / forward_speed``; the capsules are circles grown by the hull's
radius. Sweeping x from the start, the set of lateral positions reachable without touching a grown capsule or
crossing the lateral bound widens by the slope per step and loses what a capsule covers; the course is feasible
when that set is not empty at the goal line. Acceleration is ignored, so this is optimistic: a layout it calls
infeasible cannot be flown by any controller; one it calls feasible may still need more agility than the drone
has.
"""

from __future__ import annotations

import numpy as np

# Lateral resolution of the sweep (m): a gap narrower than about two cells may be missed.
LATERAL_STEP_M = 0.01


def corridor_exists(
    layout: np.ndarray,
    *,
    goal_x: float,
    forward_speed: float,
    max_lateral_speed: float,
    lateral_bound: float,
    drone_radius: float,
    start_y: float = 0.0,
    margin: float = 0.0,
    lateral_step: float = LATERAL_STEP_M,
) -> bool:
    """Whether a path from (0, ``start_y``) to the goal line ``goal_x`` keeps every capsule more than
    ``drone_radius + margin`` away and stays within ``lateral_bound``, with |dy/dx| <= ``max_lateral_speed /
    forward_speed``.

    Args:
        layout: (N, 3) capsules as x, y of the axis and radius (m); rows of zeros (padding) are ignored, so the
            env's ``layout`` key can be passed as it is.
        lateral_step: the sweep's lateral resolution (m).

    Raises:
        ValueError: ``forward_speed``, ``max_lateral_speed`` or ``lateral_step`` not > 0, or ``layout`` not (N, 3).
    """
    for name, value in (
        ("forward_speed", forward_speed),
        ("max_lateral_speed", max_lateral_speed),
        ("lateral_step", lateral_step),
    ):
        if not value > 0.0:
            raise ValueError(f"{name} must be > 0, got {value!r}")
    capsules = np.asarray(layout, np.float64)
    if capsules.ndim != 2 or capsules.shape[1] != 3:
        raise ValueError(f"layout must have shape (N, 3) of x, y, radius, got {capsules.shape}")
    capsules = capsules[capsules[:, 2] > 0.0]
    grown = capsules[:, 2] + drone_radius + margin
    slope = max_lateral_speed / forward_speed
    # One lateral cell per x step: the reachable set grows by one cell on each side per step.
    x_step = lateral_step / slope
    cells = int(np.floor(lateral_bound / lateral_step))
    ys = np.arange(-cells, cells + 1) * lateral_step
    reachable = np.abs(ys - start_y) <= lateral_step / 2
    for x in np.arange(0.0, goal_x + x_step, x_step):
        grown_set = reachable.copy()
        grown_set[1:] |= reachable[:-1]
        grown_set[:-1] |= reachable[1:]
        reachable = grown_set & ~_blocked(x, ys, capsules, grown)
        if not reachable.any():
            return False
    return True


def _blocked(x: float, ys: np.ndarray, capsules: np.ndarray, grown: np.ndarray) -> np.ndarray:
    """Which lateral positions at ``x`` lie inside a grown capsule."""
    near = np.abs(capsules[:, 0] - x) < grown
    if not near.any():
        return np.zeros(ys.shape, bool)
    half_chord = np.sqrt(grown[near] ** 2 - (capsules[near, 0] - x) ** 2)
    return (np.abs(ys[:, None] - capsules[near, 1]) < half_chord).any(axis=1)
